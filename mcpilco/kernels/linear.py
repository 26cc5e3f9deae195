"""Linear kernel on a subset of the inputs (ball-and-plate's SE + linear)."""

from __future__ import annotations

from collections.abc import Sequence

import torch

from mcpilco.errors import ConfigError
from mcpilco.kernels.base import Kernel, KernelShape, check_dims, select_dims
from mcpilco.kernels.first_order import FirstOrderCross, LinearInFeatures


class Linear(Kernel):
    """k(x, x') = x_Sᵀ Σ x'_S on the columns S = ``active_dims``, Σ diagonal and positive.

    With ``max_weight`` each entry of Σ is ``max_weight · σ(r)`` (σ the logistic function,
    r trained) instead of exp(r): a ceiling on the prior variance of every slope. Marginal
    likelihood alone lets the weight of a column that barely varies in the data grow
    without bound (the UR5's wrist torques, ~1e-3 in its exploration, reached weights of
    1e10, and the model then predicted velocity changes of ~500 rad/s per step).

    Args:
        shape: outputs and input dimension.
        weight: initial diagonal of Σ.
        active_dims: input columns S (all when None).
        max_weight: ceiling on the entries of Σ (None: none); above every initial weight.
        isotropic: Σ = σ² I, one weight for every column (thesis eq. 6.9's α₃ xᵀx').
    """

    def __init__(
        self,
        shape: KernelShape,
        weight: float | Sequence[float] = 1.0,
        active_dims: Sequence[int] | None = None,
        max_weight: float | None = None,
        isotropic: bool = False,
    ) -> None:
        super().__init__(shape)
        self.active_dims = None if active_dims is None else tuple(active_dims)
        size = check_dims("Linear", self.active_dims, shape.input_dim)
        size = 1 if self._flag("isotropic", isotropic) else size
        self.log_weight = self._log_parameter("weight", weight, size)  # [G, D_S]
        self.max_weight = max_weight
        if max_weight is not None:
            if not max_weight > float(torch.exp(self.log_weight.detach()).max()):
                raise ConfigError(
                    f"kernel Linear.max_weight must exceed the initial weight {weight!r}, "
                    f"got {max_weight!r}"
                )
            with torch.no_grad():  # r = logit(weight / max_weight), stored in log_weight
                self.log_weight.copy_(torch.logit(torch.exp(self.log_weight) / max_weight))

    def weights(self) -> torch.Tensor:
        """The diagonal of Σ, ``[G, D_S]``."""
        if self.max_weight is None:
            return torch.exp(self.log_weight)
        return self.max_weight * torch.sigmoid(self.log_weight)

    def constrained_hyperparameters(self) -> dict[str, torch.Tensor]:
        return {"weight": self.weights()}

    def forward(self, x1: torch.Tensor, x2: torch.Tensor) -> torch.Tensor:
        z1 = select_dims(x1, self.active_dims)
        z2 = select_dims(x2, self.active_dims)
        return torch.matmul(z1 * self.weights()[:, None, :], z2.transpose(-1, -2))

    def prepare_first_order(self, x2: torch.Tensor) -> FirstOrderCross:
        outputs, dims = self.shape.num_outputs, self.active_dims

        def columns(x: torch.Tensor) -> torch.Tensor:  # [M, D] -> [G, M, D_S]
            return select_dims(x, dims).expand(outputs, -1, -1)

        weight = self.weights().detach()[:, None, :]  # [G, 1, D_S] (or [G, 1, 1])
        return LinearInFeatures(columns, columns(x2).detach(), weight)

    def diag(self, x: torch.Tensor) -> torch.Tensor:
        z = select_dims(x, self.active_dims)
        return (z.square()[None] * self.weights()[:, None, :]).sum(-1)
