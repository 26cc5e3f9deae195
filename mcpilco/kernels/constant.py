"""Constant kernel: the bias term of an inhomogeneous linear kernel."""

from __future__ import annotations

import torch

from mcpilco.kernels.base import Kernel, KernelShape


class Constant(Kernel):
    """k(x, x') = c, c > 0 trained, one per output.

    ``Linear + Constant`` is the inhomogeneous linear kernel [xᵀ, 1] Φ [x'ᵀ, 1]ᵀ with
    Φ = diag(φ₁², …, φ_D², c) of thesis eq. 6.10.

    Args:
        shape: outputs and input dimension.
        value: initial c.
    """

    def __init__(self, shape: KernelShape, value: float = 1.0) -> None:
        super().__init__(shape)
        self.log_value = self._log_parameter("value", value, 1)  # [G, 1]

    def forward(self, x1: torch.Tensor, x2: torch.Tensor) -> torch.Tensor:
        value = torch.exp(self.log_value)[:, :, None]  # [G, 1, 1]
        return value.expand(-1, x1.shape[-2], x2.shape[-2])

    def diag(self, x: torch.Tensor) -> torch.Tensor:
        return torch.exp(self.log_value).expand(-1, x.shape[-2])
