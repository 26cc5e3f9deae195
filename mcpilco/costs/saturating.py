"""Saturating distance costs: 1 − exp(−Σ_i ((f_i(x) − target_i) / ℓ_i)²)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import torch

from mcpilco.costs.base import Cost
from mcpilco.errors import ConfigError


@dataclass(frozen=True)
class DistanceTerm:
    """One term: state component ``index``, its ``target`` and ``length_scale``;
    ``absolute`` compares |x_index| with the target (both upright angles ±π of §2.5)."""

    index: int
    target: float
    length_scale: float
    absolute: bool = False


class SaturatingDistance(Cost):
    """c(x) = 1 − exp(−Σ_i ((f_i(x) − target_i)/ℓ_i)²), in [0, 1).

    The cart-pole swing-up cost (2.16) is the terms (θ, |·|, π, l_θ) and (p, 0, l_p).

    Args:
        terms: the distance terms (dicts from YAML or :class:`DistanceTerm`).
    """

    def __init__(self, terms: Sequence[Mapping[str, object] | DistanceTerm]) -> None:
        super().__init__()
        parsed = [t if isinstance(t, DistanceTerm) else DistanceTerm(**t) for t in terms]  # type: ignore[arg-type]
        if not parsed:
            raise ConfigError("cost.terms must hold at least one term")
        for term in parsed:
            if term.length_scale <= 0:
                raise ConfigError(f"cost.terms length_scale must be > 0, got {term.length_scale}")
        self.indices = [t.index for t in parsed]
        self.register_buffer(
            "targets", torch.tensor([t.target for t in parsed], dtype=torch.float64)
        )
        self.register_buffer(
            "inverse_scales",
            torch.tensor([1.0 / t.length_scale for t in parsed], dtype=torch.float64),
        )
        self.register_buffer("absolute", torch.tensor([t.absolute for t in parsed]))

    def forward(self, states: torch.Tensor) -> torch.Tensor:
        """Cost ``[...]`` of states ``[..., d_x]``."""
        values = states[..., self.indices]
        values = torch.where(self.absolute, values.abs(), values)
        distance = ((values - self.targets) * self.inverse_scales).square().sum(-1)
        return 1.0 - torch.exp(-distance)
