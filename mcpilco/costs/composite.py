"""Building blocks for costs beyond a saturating distance: barriers and sums."""

from __future__ import annotations

from collections.abc import Sequence

import torch
from torch import nn

from mcpilco.costs.base import Cost
from mcpilco.errors import ConfigError


class LogisticBarrier(Cost):
    """Soft bounds on one state component (thesis eq. 3.2's c_b):
    σ(k (lower − x_i)) + σ(k (x_i − upper)), σ the logistic function — ≈ 0 inside
    (lower, upper), ≈ 1 beyond either bound.

    Args:
        index: state component i. lower, upper: the bounds (its units).
        steepness: k (1/units).
    """

    def __init__(self, index: int, lower: float, upper: float, steepness: float = 10.0) -> None:
        super().__init__()
        if not lower < upper:
            raise ConfigError(f"cost barrier needs lower < upper, got {lower}, {upper}")
        if steepness <= 0:
            raise ConfigError(f"cost barrier steepness must be > 0, got {steepness}")
        self.index, self.lower, self.upper, self.steepness = index, lower, upper, steepness

    def forward(self, states: torch.Tensor) -> torch.Tensor:
        """Cost ``[...]`` of states ``[..., d_x]``."""
        x = states[..., self.index]
        k = self.steepness
        return torch.sigmoid(k * (self.lower - x)) + torch.sigmoid(k * (x - self.upper))


class CostSum(Cost):
    """c(x) = Σ_k c_k(x) of cost modules (e.g. a saturating distance plus a barrier)."""

    def __init__(self, terms: Sequence[nn.Module]) -> None:
        super().__init__()
        if not terms:
            raise ConfigError("cost.terms must hold at least one cost")
        self.terms = nn.ModuleList(terms)

    def forward(self, states: torch.Tensor) -> torch.Tensor:
        total = self.terms[0](states)
        for term in self.terms[1:]:
            total = total + term(states)
        return total
