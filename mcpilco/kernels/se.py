"""Squared exponential kernel with ARD length-scales (thesis eq. 2.2)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import torch
from torch import nn
from torch.autograd.function import once_differentiable

from mcpilco.kernels.base import (
    Kernel,
    KernelShape,
    PreparedKernel,
    check_dims,
    cross_product,
    select_dims,
    squared_distances,
)
from mcpilco.kernels.first_order import FirstOrderCross, RowContraction


class _PreparedCross(torch.autograd.Function):
    """K = exp(2 z1·z2 − |z1|² − offset) ``[G, M, N]`` with z1 = x1 ⊙ ι (inverse
    length-scales ``[G, 1, D]``) and a hand-written backward: ∂K/∂z1 needs only K itself
    (h = g ⊙ K; g_z1 = h (2 z2) − 2 z1 Σ_n h, one product with the training side;
    g_x1 = Σ_G g_z1 ⊙ ι), which saves autograd's temporaries on the largest tensor of a
    rollout step. Training-side arguments and ι are constants (no gradient).

    The exponent is one product of the training side ``[2 z2 | −1 | −offset]`` ``[G, N,
    D+2]`` with ``[z1 | |z1|² | 1]`` (:func:`~mcpilco.kernels.base.cross_product`: for a
    particle batch computed as Kᵀ ``[G, N, M]`` and returned column-major, the layout the
    triangular solves of a whitened prediction take without a transposing copy), then one
    exp pass over its memory."""

    @staticmethod
    def forward(
        ctx: Any, x1: torch.Tensor, inverse_lengthscale: torch.Tensor, training: torch.Tensor
    ) -> torch.Tensor:
        z1 = x1 * inverse_lengthscale  # [G, M, D]
        covariance = _PreparedCross.covariance(z1, training)
        ctx.save_for_backward(inverse_lengthscale, z1, training, covariance)
        return covariance

    @staticmethod
    def covariance(z1: torch.Tensor, training: torch.Tensor) -> torch.Tensor:
        """K ``[G, M, N]`` from z1 ``[G, M, D]`` and the training side."""
        augmented = torch.cat(
            [z1, z1.square().sum(-1, keepdim=True), torch.ones_like(z1[..., :1])], -1
        )
        return cross_product(training, augmented).exp_()

    @staticmethod
    @once_differentiable
    def backward(ctx: Any, grad: torch.Tensor) -> tuple[torch.Tensor, None, None]:
        inverse_lengthscale, z1, training, covariance = ctx.saved_tensors
        weighted_t = (grad * covariance).mT  # [G, N, M]
        dim = z1.shape[-1]
        # as (training side)ᵀ · weightedᵀ: the skinny-output product is ~4× faster this way
        grad_augmented = torch.matmul(training[..., : dim + 1].mT, weighted_t).mT  # [G, M, D+1]
        grad_z1 = grad_augmented[..., :dim].addcmul_(z1, grad_augmented[..., dim:], value=2.0)
        return (grad_z1 * inverse_lengthscale).sum(0), None, None


class SquaredExponential(Kernel):
    """k(x, x') = λ² exp(−Σ_d (x_d − x'_d)² / ℓ_d²), one (λ, ℓ) per output.

    Note the thesis writes ‖x − x'‖²_Λ without the usual ½; ℓ here absorbs it.

    Args:
        shape: outputs and input dimension.
        lengthscale: initial ℓ (one value or one per active input).
        variance: initial λ².
        train_variance: whether λ² is a trained hyper-parameter.
        active_dims: input columns the kernel looks at (all when None).
        isotropic: one length-scale shared by every input (the GPDM kernels of thesis
            eq. 6.6 and 6.9) instead of one per input (ARD).
    """

    def __init__(
        self,
        shape: KernelShape,
        lengthscale: float | Sequence[float] = 1.0,
        variance: float = 1.0,
        train_variance: bool = True,
        active_dims: Sequence[int] | None = None,
        isotropic: bool = False,
    ) -> None:
        super().__init__(shape)
        self.active_dims = None if active_dims is None else tuple(active_dims)
        size = check_dims("SquaredExponential", self.active_dims, shape.input_dim)
        size = 1 if self._flag("isotropic", isotropic) else size
        self.log_lengthscale = self._log_parameter("lengthscale", lengthscale, size)
        log_variance = self._log_parameter("variance", variance, 1)[:, 0]
        self.log_variance = nn.Parameter(
            log_variance, requires_grad=self._flag("train_variance", train_variance)
        )

    def forward(self, x1: torch.Tensor, x2: torch.Tensor) -> torch.Tensor:
        inverse_lengthscale = torch.exp(-self.log_lengthscale)[:, None, :]  # [G, 1, D]
        z1 = select_dims(x1, self.active_dims) * inverse_lengthscale  # [G, N1, D]
        z2 = select_dims(x2, self.active_dims) * inverse_lengthscale  # [G, N2, D]
        return torch.exp(self.log_variance[:, None, None] - squared_distances(z1, z2))

    def prepare(self, x2: torch.Tensor) -> PreparedKernel:
        """k(x1, x2) = exp(2 z1·z2 − |z1|² − (|z2|² − log λ²)) with z = x/ℓ; the x2 terms
        are computed once, leaving one batched matmul and one exp per call
        (:class:`_PreparedCross`)."""
        inverse_lengthscale, training = self._training_side(x2)
        prior_variance = torch.exp(self.log_variance)[:, None]  # [G, 1]
        dims = self.active_dims

        def cross(x1: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
            covariance = _PreparedCross.apply(select_dims(x1, dims), inverse_lengthscale, training)
            return covariance, prior_variance.expand(-1, x1.shape[-2])

        return cross

    def _training_side(self, x2: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Constants of predictions at training inputs ``x2`` (no gradient to ι): ι ``[G, 1,
        D]`` and the training side ``[2 z2 | −1 | −offset]`` ``[G, N, D+2]`` with z2 = x2 ⊙ ι
        and offset = |z2|² − log λ²."""
        inverse_lengthscale = torch.exp(-self.log_lengthscale).detach()[:, None, :]  # [G, 1, D]
        z2 = select_dims(x2, self.active_dims) * inverse_lengthscale  # [G, N, D]
        offset = z2.square().sum(-1, keepdim=True) - self.log_variance[:, None, None]  # [G, N, 1]
        return inverse_lengthscale, torch.cat([2.0 * z2, -torch.ones_like(offset), -offset], -1)

    def prepare_first_order(self, x2: torch.Tensor) -> FirstOrderCross:
        inverse_lengthscale, training = self._training_side(x2)
        variance = torch.exp(self.log_variance.detach())[:, None]  # [G, 1]
        return _FirstOrderSE(inverse_lengthscale, training.detach(), variance, self.active_dims)

    @torch.no_grad()
    def step_factors(
        self, x2: torch.Tensor, columns: Sequence[int], steps: Sequence[float]
    ) -> torch.Tensor:
        """From x_c = 0 to s the exponent −(x_c − x2_c)²/ℓ_c² grows by (2 s x2_c − s²)/ℓ_c²,
        so F_c = exp((2 s x2_c − s²)/ℓ_c²) (1 for a column the kernel does not look at)."""
        dims = self.active_dims if self.active_dims is not None else range(x2.shape[-1])
        dims = list(dims)
        inverse_square = torch.exp(-2.0 * self.log_lengthscale)  # [G, D or 1]
        factors = torch.ones(
            self.shape.num_outputs, len(columns), x2.shape[-2], dtype=x2.dtype, device=x2.device
        )
        for i, (column, step) in enumerate(zip(columns, steps, strict=True)):
            if column in dims:
                weight = inverse_square[:, dims.index(column) if inverse_square.shape[1] > 1 else 0]
                factors[:, i] = torch.exp((2.0 * step * x2[:, column] - step**2) * weight[:, None])
        return factors

    def diag(self, x: torch.Tensor) -> torch.Tensor:
        return torch.exp(self.log_variance)[:, None].expand(-1, x.shape[-2])


class _FirstOrderSE(FirstOrderCross):
    """SE cross-covariance on features f = x* ⊙ ι (ι: inverse length-scales): k_ij =
    exp(2 f_i·z2_j − |f_i|² − offset_j), so ∂k_ij/∂f_i = k_ij (2 z2_j − 2 f_i) and any
    contraction Σ_j w_ij ∂k_ij/∂f_i is Σ_j (w ⊙ k)_ij 2 z2_j − 2 f_i Σ_j (w ⊙ k)_ij: one
    product of w ⊙ k with the training side ``[2 z2 | −1]``, whose last column gives
    Σ_j w_ij k_ij too."""

    def __init__(
        self,
        inverse_lengthscale: torch.Tensor,
        training: torch.Tensor,
        variance: torch.Tensor,
        active_dims: tuple[int, ...] | None,
    ) -> None:
        self.inverse_lengthscale = inverse_lengthscale  # [G, 1, D]
        self.training = training  # [2 z2 | −1 | −offset] [G, N, D+2]
        self.variance = variance  # λ² [G, 1]
        self.active_dims = active_dims

    @property
    def num_features(self) -> int:
        return self.inverse_lengthscale.shape[-1]

    def features(self, x1: torch.Tensor) -> torch.Tensor:
        return select_dims(x1, self.active_dims) * self.inverse_lengthscale

    def covariance(self, features: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        augmented = torch.cat(
            [features, features.square().sum(-1, keepdim=True), torch.ones_like(features[..., :1])],
            -1,
        )
        covariance_t = torch.matmul(self.training, augmented.mT).exp_()  # [G, N, M]
        return covariance_t, covariance_t

    def prior_variance(self, features: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        prior = self.variance.expand(-1, features.shape[-2])
        return prior, torch.zeros_like(features)

    def contract(
        self, features: torch.Tensor, state: torch.Tensor, weights_t: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        dim = self.num_features
        sums = torch.matmul(self.training[..., : dim + 1].mT, weights_t * state)  # [G, D+1, M]
        total = -sums[..., dim, :]
        return sums[..., :dim, :].mT - 2.0 * features * total.unsqueeze(-1), total

    def row_contraction(self, row_weights: torch.Tensor) -> RowContraction:
        # [2 z2 | −1]: k*·columns gives Σ_j a_j k_ij 2 z2_j and −Σ_j a_j k_ij of this kernel
        columns = row_weights.unsqueeze(-1) * self.training[..., : self.num_features + 1]

        def finish(features: torch.Tensor, state: Any, folded: torch.Tensor) -> torch.Tensor:
            return folded[..., :-1] + 2.0 * features * folded[..., -1:]

        return RowContraction(columns, finish)
