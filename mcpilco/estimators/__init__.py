"""State estimators: offline (training data) and online (closed loop, simulated in rollouts)."""

from mcpilco.estimators.base import StateEstimator
from mcpilco.estimators.difference import CausalDifference, ZeroPhaseDifference
from mcpilco.estimators.held_input import HeldInputSmoother
from mcpilco.estimators.identity import FullStateMeasurement
from mcpilco.estimators.kalman import KalmanEstimator
from mcpilco.estimators.positions import PositionBasedEstimator

__all__ = [
    "CausalDifference",
    "FullStateMeasurement",
    "HeldInputSmoother",
    "KalmanEstimator",
    "PositionBasedEstimator",
    "StateEstimator",
    "ZeroPhaseDifference",
]
