"""Systems: the plants a policy is learned for (one file per plant, one interface)."""

from mcpilco.systems.ball_and_plate import BallAndPlate
from mcpilco.systems.base import Controller, MechanicalSystem, OdeSystem
from mcpilco.systems.cartpole import CartPole
from mcpilco.systems.cartpole_mujoco import CartPoleMujoco
from mcpilco.systems.furuta import FurutaPendulum
from mcpilco.systems.gymnasium_env import GymnasiumSystem
from mcpilco.systems.sensors import Sensors
from mcpilco.systems.ur5 import UR5

__all__ = [
    "BallAndPlate",
    "CartPole",
    "CartPoleMujoco",
    "Controller",
    "FurutaPendulum",
    "GymnasiumSystem",
    "MechanicalSystem",
    "OdeSystem",
    "Sensors",
    "UR5",
]
