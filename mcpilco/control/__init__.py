"""GP inverse dynamics and feedback-linearisation torque control (thesis chapter 5)."""

from mcpilco.control.controllers import GPFL, GPFLDCE, TrackingController, TrueModelFL
from mcpilco.control.data import InverseDynamicsData, collect
from mcpilco.control.inverse_dynamics import GPInverseDynamics, nmse_percent
from mcpilco.control.references import SineReference, filtered_noise
from mcpilco.control.robot import PyBulletArm, TorqueControlledRobot
from mcpilco.control.tracking import TrackingRun, track

__all__ = [
    "GPFL",
    "GPFLDCE",
    "GPInverseDynamics",
    "InverseDynamicsData",
    "PyBulletArm",
    "SineReference",
    "TorqueControlledRobot",
    "TrackingController",
    "TrackingRun",
    "TrueModelFL",
    "collect",
    "filtered_noise",
    "nmse_percent",
    "track",
]
