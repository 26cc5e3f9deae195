"""Multiplicative polynomial kernel (thesis §2.3.2, the P in SE+P(d))."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import torch
from torch import nn

from mcpilco.errors import ConfigError
from mcpilco.kernels.base import Kernel, KernelShape, check_dims, select_dims


class MultiplicativePolynomial(Kernel):
    """k(x, x') = ∏_{r=1..d} (σ²_r + xᵀ Σ_r x'), Σ_r diagonal and positive.

    Args:
        shape: outputs and input dimension.
        degree: d ≥ 1.
        offset: initial σ²_r. weight: initial diagonal of Σ_r.
        active_dims: input columns the kernel looks at (all when None).
    """

    def __init__(
        self,
        shape: KernelShape,
        degree: int = 2,
        offset: float = 1.0,
        weight: float | Sequence[float] = 1.0,
        active_dims: Sequence[int] | None = None,
    ) -> None:
        super().__init__(shape)
        if degree < 1:
            raise ConfigError(f"kernel MultiplicativePolynomial.degree must be >= 1, got {degree}")
        self.active_dims = None if active_dims is None else tuple(active_dims)
        size = check_dims("MultiplicativePolynomial", self.active_dims, shape.input_dim)
        self.log_offset = nn.Parameter(
            torch.stack([self._log_parameter("offset", offset, 1)[:, 0] for _ in range(degree)], 1)
        )  # [G, d]
        self.log_weight = nn.Parameter(
            torch.stack([self._log_parameter("weight", weight, size) for _ in range(degree)], 1)
        )  # [G, d, D]

    def forward(self, x1: torch.Tensor, x2: torch.Tensor) -> torch.Tensor:
        z1 = select_dims(x1, self.active_dims)
        z2 = select_dims(x2, self.active_dims)
        weights = torch.exp(self.log_weight)  # [G, d, D]
        factors = torch.matmul(z1 * weights[:, :, None, :], z2.transpose(-1, -2))  # [G,d,N1,N2]
        factors = factors + torch.exp(self.log_offset)[:, :, None, None]
        return factors.prod(dim=1)

    def prepare_cross(self, x2: torch.Tensor) -> Callable[[torch.Tensor], torch.Tensor]:
        """``x1 ↦ k(x1, x2) [G, M, N]`` with ``x2``'s columns selected and laid out once."""
        z2 = select_dims(x2, self.active_dims).T.contiguous()  # [D, N]
        weights, offsets = torch.exp(self.log_weight), torch.exp(self.log_offset)

        def cross(x1: torch.Tensor) -> torch.Tensor:
            z1 = select_dims(x1, self.active_dims)
            factors = torch.matmul(z1 * weights[:, :, None, :], z2)  # [G, d, M, N]
            return (factors + offsets[:, :, None, None]).prod(dim=1)

        return cross

    def diag(self, x: torch.Tensor) -> torch.Tensor:
        z = select_dims(x, self.active_dims)
        weights = torch.exp(self.log_weight)  # [G, d, D]
        factors = torch.einsum("nd,grd->grn", z.square(), weights)
        return (factors + torch.exp(self.log_offset)[:, :, None]).prod(dim=1)
