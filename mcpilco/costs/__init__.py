"""Costs c(x) on states ``[..., d_x]``, differentiable in torch (one file per family)."""

from mcpilco.costs.composite import CostSum, LogisticBarrier
from mcpilco.costs.saturating import DistanceTerm, SaturatingDistance

__all__ = ["CostSum", "DistanceTerm", "LogisticBarrier", "SaturatingDistance"]
