"""Posterior samples whose gradient is formed in the forward pass (inverse form, float64).

A reparameterised sample s_i = mean_i + std_i ε_i of test point i depends on that point
alone, through its kernel features f_i (:mod:`mcpilco.kernels.first_order`). With
k* ``[G, M, N]``, W = Γ⁻¹k*ᵀ and a kernel that contracts its own derivatives:

    ∂mean_i/∂f_i = Σ_j α_j ∂k_ij/∂f_i       (folded into the product that gives W)
    ∂quad_i/∂f_i = 2 Σ_j W_ji ∂k_ij/∂f_i     (quad_i = Σ_j W_ji k_ij comes with it)
    ∂s_i/∂f_i = ∂mean_i/∂f_i + ε_i / (2 std_i) (∂k**_i/∂f_i − ∂quad_i/∂f_i)

all ``[G, M, F]``, computed while k* and W are in cache. The backward pass multiplies that
Jacobian by the incoming gradient; no ``[G, N, M]`` tensor is kept between the passes (the
plain form, :func:`~mcpilco.gp.prediction.posterior_sample`, keeps Γ⁻¹k*ᵀ and k* of every
time step of a rollout for the backward pass and reads them again there). The flops are
those of the plain form; the numbers agree with it to rounding.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import torch
from torch.autograd.function import once_differentiable

from mcpilco.gp.prediction import VARIANCE_FLOOR
from mcpilco.kernels.first_order import FirstOrderCross, RowFinish


class _FirstOrderSample(torch.autograd.Function):
    @staticmethod
    def forward(
        ctx: Any,
        features: torch.Tensor,
        kernel: FirstOrderCross,
        extended: torch.Tensor,
        finish: RowFinish,
        noise: torch.Tensor,
    ) -> torch.Tensor:
        covariance_t, state = kernel.covariance(features)  # [G, N, M]
        num_train = covariance_t.shape[-2]
        products = torch.matmul(extended.mT, covariance_t)  # [G, N+1+C, M]
        weighted_t = products[..., :num_train, :]  # Γ⁻¹ k*ᵀ
        mean = products[..., num_train, :]
        mean_gradient = finish(features, state, products[..., num_train + 1 :, :].mT)
        quadratic_half_gradient, quadratic = kernel.contract(features, state, weighted_t)
        prior, prior_gradient = kernel.prior_variance(features)
        variance = prior - quadratic
        clamped = variance < VARIANCE_FLOOR
        std = variance.clamp_min_(VARIANCE_FLOOR).sqrt_()
        std_factor = (noise / std).mul_(0.5).masked_fill_(clamped, 0.0)  # ∂s/∂variance
        variance_gradient = prior_gradient - 2.0 * quadratic_half_gradient  # [G, M, F]
        jacobian = torch.addcmul(mean_gradient, variance_gradient, std_factor.unsqueeze(-1))
        ctx.save_for_backward(jacobian)
        return torch.addcmul(mean, std, noise)

    @staticmethod
    @once_differentiable
    def backward(ctx: Any, grad: torch.Tensor) -> tuple[torch.Tensor, None, None, None, None]:
        (jacobian,) = ctx.saved_tensors
        return grad.unsqueeze(-1) * jacobian, None, None, None, None


@dataclass(frozen=True)
class FirstOrderForm:
    """What first-order samples of one fitted GP reuse (built once per fit, float64).

    Attributes:
        kernel: the prepared kernel (:meth:`~mcpilco.kernels.base.Kernel.prepare_first_order`).
        extended: ``[Γ⁻¹ | α | columns]`` ``[G, N, N+1+C]``, the row contraction's columns
            for α beside the plain form's ``[Γ⁻¹ | α]`` (a constant).
        finish: the same row contraction's ``finish``.
    """

    kernel: FirstOrderCross
    extended: torch.Tensor
    finish: RowFinish

    @classmethod
    def from_solve(cls, kernel: FirstOrderCross, solve: torch.Tensor) -> FirstOrderForm:
        """The form from the plain ``solve`` = [Γ⁻¹ | α] ``[G, N, N+1]``."""
        contraction = kernel.row_contraction(solve[..., -1])
        columns = contraction.columns.to(solve.dtype)
        extended = torch.cat([solve, columns], dim=-1).detach().contiguous()
        return cls(kernel, extended, contraction.finish)

    @property
    def solve(self) -> torch.Tensor:
        """[Γ⁻¹ | α] ``[G, N, N+1]`` as a view of ``extended`` (Γ⁻¹ is stored once)."""
        return self.extended[..., : self.extended.shape[-2] + 1]

    def sample(self, inputs: torch.Tensor, noise: torch.Tensor) -> torch.Tensor:
        """Reparameterised sample mean + std ⊙ noise ``[G, M]`` of the latent posterior at
        ``inputs [M, D]``, differentiable w.r.t. ``inputs`` (through the kernel's
        features); ``noise``: standard normal ``[G, M]`` (constant)."""
        features = self.kernel.features(inputs)
        return _FirstOrderSample.apply(
            features, self.kernel, self.extended, self.finish, noise.detach()
        )
