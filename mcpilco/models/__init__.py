"""Model structures: how GP predictions become particle transitions."""

from mcpilco.models.base import FitReport, ModelStructure
from mcpilco.models.derivative_free import DerivativeFree
from mcpilco.models.features import AngleFeatures
from mcpilco.models.full_state import FullState
from mcpilco.models.speed_integration import SpeedIntegration
from mcpilco.models.true_dynamics import TrueDynamics

__all__ = [
    "AngleFeatures",
    "DerivativeFree",
    "FitReport",
    "FullState",
    "ModelStructure",
    "SpeedIntegration",
    "TrueDynamics",
]
