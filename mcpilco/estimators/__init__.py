"""State estimators: offline (training data) and online (closed loop, simulated in rollouts)."""

from mcpilco.estimators.base import StateEstimator
from mcpilco.estimators.identity import FullStateMeasurement

__all__ = ["FullStateMeasurement", "StateEstimator"]
