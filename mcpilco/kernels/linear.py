"""Linear kernel on a subset of the inputs (ball-and-plate's SE + linear)."""

from __future__ import annotations

from collections.abc import Sequence

import torch

from mcpilco.kernels.base import Kernel, KernelShape, check_dims, select_dims


class Linear(Kernel):
    """k(x, x') = x_Sᵀ Σ x'_S on the columns S = ``active_dims``, Σ diagonal and positive.

    Args:
        shape: outputs and input dimension.
        weight: initial diagonal of Σ.
        active_dims: input columns S (all when None).
    """

    def __init__(
        self,
        shape: KernelShape,
        weight: float | Sequence[float] = 1.0,
        active_dims: Sequence[int] | None = None,
    ) -> None:
        super().__init__(shape)
        self.active_dims = None if active_dims is None else tuple(active_dims)
        size = check_dims("Linear", self.active_dims, shape.input_dim)
        self.log_weight = self._log_parameter("weight", weight, size)  # [G, D_S]

    def forward(self, x1: torch.Tensor, x2: torch.Tensor) -> torch.Tensor:
        z1 = select_dims(x1, self.active_dims)
        z2 = select_dims(x2, self.active_dims)
        return torch.matmul(z1 * torch.exp(self.log_weight)[:, None, :], z2.transpose(-1, -2))

    def diag(self, x: torch.Tensor) -> torch.Tensor:
        z = select_dims(x, self.active_dims)
        return torch.matmul(torch.exp(self.log_weight), z.square().transpose(-1, -2))
