"""Sum of kernels (SE+P(d), SP, SE + linear on a subset, ...)."""

from __future__ import annotations

from collections.abc import Sequence

import torch
from torch import nn

from mcpilco.errors import ConfigError
from mcpilco.kernels.base import Kernel, KernelFactory, KernelShape, PreparedKernel


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

    def diag(self, x: torch.Tensor) -> torch.Tensor:
        total = self.terms[0].diag(x)
        for term in self.terms[1:]:
            total = total + term.diag(x)
        return total
