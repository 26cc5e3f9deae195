"""Physically-inspired (PI) kernel: a linear kernel on basis functions from the physics."""

from __future__ import annotations

from collections.abc import Sequence

import torch

from mcpilco.errors import ConfigError
from mcpilco.kernels.base import Kernel, KernelShape, PreparedKernel, cross_product
from mcpilco.kernels.first_order import FirstOrderCross, LinearInFeatures


class PhysicalBasis(Kernel):
    """k(x, x') = φ(x)ᵀ Σ_PI φ(x'), Σ_PI diagonal and positive, φ per output.

    The basis comes from the model structure (which asks the system for it) through
    ``shape.basis``: GP inputs ``[N, D]`` → features ``[G, N, P]``. Add an SE kernel to it
    (:class:`Sum`) to get the semi-parametric (SP) kernel of §2.3.2.

    Args:
        shape: outputs, input dimension and the basis.
        weight: initial diagonal of Σ_PI (one value or one per feature).
    """

    def __init__(self, shape: KernelShape, weight: float | Sequence[float] = 1.0) -> None:
        super().__init__(shape)
        if shape.basis is None:
            raise ConfigError(
                "kernel PhysicalBasis needs a physical basis, but the system/model gives none"
            )
        self.basis = shape.basis
        probe = self.basis(torch.zeros(1, shape.input_dim, dtype=torch.float64))
        if probe.dim() != 3 or probe.shape[0] != shape.num_outputs:
            raise ConfigError(
                f"kernel PhysicalBasis: basis gives shape {tuple(probe.shape)}, "
                f"expected [{shape.num_outputs}, N, P]"
            )
        self.log_weight = self._log_parameter("weight", weight, probe.shape[-1])  # [G, P]

    def forward(self, x1: torch.Tensor, x2: torch.Tensor) -> torch.Tensor:
        phi1 = self.basis(x1)  # [G, N1, P]
        phi2 = phi1 if x2 is x1 else self.basis(x2)
        return torch.matmul(phi1 * torch.exp(self.log_weight)[:, None, :], phi2.transpose(-1, -2))

    def prepare(self, x2: torch.Tensor) -> PreparedKernel:
        weight = torch.exp(self.log_weight)[:, None, :]  # [G, 1, P]
        weighted = self.basis(x2) * weight  # [G, N, P]

        def cross(x1: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
            phi = self.basis(x1)  # [G, M, P]
            return cross_product(weighted, phi), (phi.square() * weight).sum(-1)

        return cross

    def prepare_first_order(self, x2: torch.Tensor) -> FirstOrderCross:
        weight = torch.exp(self.log_weight).detach()[:, None, :]  # [G, 1, P]
        return LinearInFeatures(self.basis, self.basis(x2).detach(), weight)

    def diag(self, x: torch.Tensor) -> torch.Tensor:
        phi = self.basis(x)
        return (phi.square() * torch.exp(self.log_weight)[:, None, :]).sum(-1)
