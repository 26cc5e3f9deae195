"""Costs c(x) on states ``[..., d_x]``, differentiable in torch (one file per family)."""

from mcpilco.costs.base import Cost
from mcpilco.costs.composite import CostSum, LogisticBarrier
from mcpilco.costs.quadratic import SaturatingQuadratic
from mcpilco.costs.saturating import DistanceTerm, SaturatingDistance
from mcpilco.costs.tracking import TrackingCost

__all__ = [
    "Cost",
    "CostSum",
    "DistanceTerm",
    "LogisticBarrier",
    "SaturatingDistance",
    "SaturatingQuadratic",
    "TrackingCost",
]
