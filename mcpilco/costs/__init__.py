"""Costs the policy is optimised for (one file per family)."""

from mcpilco.costs.saturating import DistanceTerm, SaturatingDistance

__all__ = ["DistanceTerm", "SaturatingDistance"]
