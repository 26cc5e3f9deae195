"""Sum of kernels (SE+P(d), SP, SE + linear on a subset, ...)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import torch
from torch import nn

from mcpilco.errors import ConfigError
from mcpilco.kernels.base import Kernel, KernelFactory, KernelShape, PreparedKernel
from mcpilco.kernels.first_order import FirstOrderCross, RowContraction


class Sum(Kernel):
    """k = Σ_i k_i; ``terms`` are kernel factories completed with the same shape."""

    def __init__(self, shape: KernelShape, terms: Sequence[KernelFactory]) -> None:
        super().__init__(shape)
        if len(terms) == 0:
            raise ConfigError("kernel Sum.terms must name at least one kernel")
        self.terms = nn.ModuleList([make(shape) for make in terms])

    def forward(self, x1: torch.Tensor, x2: torch.Tensor) -> torch.Tensor:
        total = self.terms[0](x1, x2)
        for term in self.terms[1:]:
            total = total + term(x1, x2)
        return total

    def prepare(self, x2: torch.Tensor) -> PreparedKernel:
        parts = [term.prepare(x2) for term in self.terms]

        def cross(x1: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
            covariance, variance = parts[0](x1)
            for part in parts[1:]:
                more_covariance, more_variance = part(x1)
                covariance = covariance + more_covariance
                variance = variance + more_variance
            return covariance, variance

        return cross

    def prepare_first_order(self, x2: torch.Tensor) -> FirstOrderCross | None:
        parts = [term.prepare_first_order(x2) for term in self.terms]
        if any(part is None for part in parts):
            return None
        return _FirstOrderSum([part for part in parts if part is not None])

    def diag(self, x: torch.Tensor) -> torch.Tensor:
        total = self.terms[0].diag(x)
        for term in self.terms[1:]:
            total = total + term.diag(x)
        return total


class _FirstOrderSum(FirstOrderCross):
    """The terms' features side by side; covariances and Σ_j w_ij k_ij add up, each
    term contracts its own slice of the features."""

    def __init__(self, parts: list[FirstOrderCross]) -> None:
        self.parts = parts
        self.sizes = [part.num_features for part in parts]

    @property
    def num_features(self) -> int:
        return sum(self.sizes)

    def _terms(self, features: torch.Tensor) -> zip[tuple[FirstOrderCross, torch.Tensor]]:
        """(term, its slice of the features) pairs."""
        return zip(self.parts, torch.split(features, self.sizes, dim=-1), strict=True)

    def features(self, x1: torch.Tensor) -> torch.Tensor:
        return torch.cat([part.features(x1) for part in self.parts], -1)

    def covariance(self, features: torch.Tensor) -> tuple[torch.Tensor, list[Any]]:
        pieces = [part.covariance(f) for part, f in self._terms(features)]
        total = pieces[0][0]  # out of place below: a term's state may be its covariance
        for covariance_t, _ in pieces[1:]:
            total = total + covariance_t
        return total, [state for _, state in pieces]

    def prior_variance(self, features: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        pieces = [part.prior_variance(f) for part, f in self._terms(features)]
        total = pieces[0][0]
        for prior, _ in pieces[1:]:
            total = total + prior
        return total, torch.cat([gradient for _, gradient in pieces], -1)

    def contract(
        self, features: torch.Tensor, state: list[Any], weights_t: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        pieces = [
            part.contract(f, part_state, weights_t)
            for (part, f), part_state in zip(self._terms(features), state, strict=True)
        ]
        total = pieces[0][1]
        for _, more in pieces[1:]:
            total = total + more
        return torch.cat([gradient for gradient, _ in pieces], -1), total

    def row_contraction(self, row_weights: torch.Tensor) -> RowContraction:
        # k* is the sum's, so no term can fold its contraction into the GP's product: each
        # contracts the weights (the same for every test point) with its own state
        weights_t = row_weights.unsqueeze(-1)  # [G, N, 1], broadcast over the test points

        def finish(features: torch.Tensor, state: Any, folded: torch.Tensor) -> torch.Tensor:
            splits = zip(self._terms(features), state, strict=True)
            return torch.cat(
                [part.contract(f, part_state, weights_t)[0] for (part, f), part_state in splits],
                -1,
            )

        return RowContraction(weights_t[..., :0], finish)
