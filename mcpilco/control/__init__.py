"""GP inverse dynamics and feedback-linearisation torque control (thesis chapter 5)."""

from mcpilco.control.controllers import GPFL, GPFLDCE, TrackingController, TrueModelFL
from mcpilco.control.data import InverseDynamicsData, collect
from mcpilco.control.inverse_dynamics import GPInverseDynamics, nmse_percent
from mcpilco.control.pybullet_arm import PyBulletArm
from mcpilco.control.reference_families import (
    RandomSumOfSines,
    ReferenceFamily,
    SumOfSines,
    ThesisSines,
)
from mcpilco.control.reference_file import FileReference, TrajectoryFile
from mcpilco.control.references import (
    Reference,
    SineReference,
    SumOfSinesReference,
    filtered_noise,
)
from mcpilco.control.robot import TorqueControlledRobot
from mcpilco.control.tracking import TrackingRun, track

__all__ = [
    "GPFL",
    "GPFLDCE",
    "FileReference",
    "GPInverseDynamics",
    "InverseDynamicsData",
    "PyBulletArm",
    "RandomSumOfSines",
    "Reference",
    "ReferenceFamily",
    "SineReference",
    "SumOfSines",
    "SumOfSinesReference",
    "ThesisSines",
    "TorqueControlledRobot",
    "TrackingController",
    "TrackingRun",
    "TrajectoryFile",
    "TrueModelFL",
    "collect",
    "filtered_noise",
    "nmse_percent",
    "track",
]
