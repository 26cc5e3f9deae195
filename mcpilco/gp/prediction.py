"""GP predictive mean and variance with a hand-written gradient.

For a fixed training set, the predictive mean and the data-dependent part of the variance
of test inputs are functions of the cross-covariances k* = k(x*, X) only:

    mean = k* α,    quad = k* Γ⁻¹ k*ᵀ (its diagonal),    α = Γ⁻¹ y.

Both products come from one batched matmul with the precomputed ``[Γ⁻¹ | α]``
(:func:`solve_matrix`). Autograd would spend a second n×n product per particle in the
backward pass; the gradient is known in closed form (∂mean/∂k* = α, ∂quad/∂k* = 2 Γ⁻¹ k*),
and Γ⁻¹ k* is already computed in the forward pass, so the backward pass needs no matrix
product at all.
"""

from __future__ import annotations

from typing import Any

import torch
from torch.autograd.function import once_differentiable


def solve_matrix(inverse_gram: torch.Tensor, alpha: torch.Tensor) -> torch.Tensor:
    """``[Γ⁻¹ | α]`` ``[G, N, N+1]`` from Γ⁻¹ ``[G, N, N]`` and α ``[G, N]`` (compute once
    per fitted GP)."""
    return torch.cat([inverse_gram, alpha.unsqueeze(-1)], dim=-1).detach().contiguous()


def _products(
    cross: torch.Tensor, solve: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Γ⁻¹ k*ᵀ ``[G, N, M]``, mean k* α ``[G, M]`` and quadratic k* Γ⁻¹ k*ᵀ ``[G, M]``,
    computed on the N × M side (k* comes column-major: see
    :data:`~mcpilco.kernels.base.PreparedKernel`)."""
    products = torch.matmul(solve.mT, cross.mT)  # [G, N+1, M]
    weighted_t, mean = products[..., :-1, :], products[..., -1, :]
    return weighted_t, mean, torch.linalg.vecdot(weighted_t, cross.mT, dim=-2)


def _cross_gradient(
    weighted_t: torch.Tensor,
    alpha: torch.Tensor,
    grad_mean: torch.Tensor,
    grad_quadratic: torch.Tensor,
) -> torch.Tensor:
    """∂/∂k* ``[G, M, N]`` (column-major): α for the mean, 2 Γ⁻¹ k* for the quadratic."""
    grad_t = alpha.unsqueeze(-1) * grad_mean.unsqueeze(-2)  # [G, N, M]
    return grad_t.addcmul_(weighted_t, grad_quadratic.unsqueeze(-2), value=2.0).mT


class _MeanAndQuadratic(torch.autograd.Function):
    @staticmethod
    def forward(ctx: Any, cross: torch.Tensor, solve: torch.Tensor) -> tuple[torch.Tensor, ...]:
        weighted_t, mean, quadratic = _products(cross, solve)
        ctx.save_for_backward(weighted_t, solve)
        return mean, quadratic

    @staticmethod
    @once_differentiable
    def backward(
        ctx: Any, grad_mean: torch.Tensor, grad_quadratic: torch.Tensor
    ) -> tuple[torch.Tensor, None]:
        weighted_t, solve = ctx.saved_tensors
        return _cross_gradient(weighted_t, solve[..., -1], grad_mean, grad_quadratic), None


def mean_and_quadratic(
    cross: torch.Tensor, solve: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    """``(k* α, diag(k* Γ⁻¹ k*ᵀ))``, each ``[G, M]``.

    Args:
        cross: k(x*, X) ``[G, M, N]`` (may require grad).
        solve: ``[Γ⁻¹ | α]`` ``[G, N, N+1]`` from :func:`solve_matrix`, a constant.
    """
    return _MeanAndQuadratic.apply(cross, solve.detach())


VARIANCE_FLOOR = 1e-12
"""Posterior variances below this are clamped (their gradient is then zero)."""


class _PosteriorSample(torch.autograd.Function):
    @staticmethod
    def forward(
        ctx: Any,
        cross: torch.Tensor,
        prior_variance: torch.Tensor,
        solve: torch.Tensor,
        noise: torch.Tensor,
    ) -> torch.Tensor:
        weighted_t, mean, quadratic = _products(cross, solve)
        variance = prior_variance - quadratic
        clamped = variance < VARIANCE_FLOOR
        std = variance.clamp_min_(VARIANCE_FLOOR).sqrt_()
        ctx.save_for_backward(weighted_t, solve, noise, std, clamped)
        return torch.addcmul(mean, std, noise)

    @staticmethod
    @once_differentiable
    def backward(ctx: Any, grad: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, None, None]:
        weighted_t, solve, noise, std, clamped = ctx.saved_tensors
        grad_variance = (grad * noise).div_(std).mul_(0.5).masked_fill_(clamped, 0.0)  # [G, M]
        grad_cross = _cross_gradient(weighted_t, solve[..., -1], grad, -grad_variance)
        return grad_cross, grad_variance, None, None


def posterior_sample(
    cross: torch.Tensor, prior_variance: torch.Tensor, solve: torch.Tensor, noise: torch.Tensor
) -> torch.Tensor:
    """Reparameterised sample mean + std ⊙ noise of the latent posterior, ``[G, M]``.

    Args:
        cross: k(x*, X) ``[G, M, N]``. prior_variance: k(x*, x*) ``[G, M]``.
        solve: ``[Γ⁻¹ | α]`` ``[G, N, N+1]`` from :func:`solve_matrix` (a constant).
        noise: standard normal ``[G, M]`` (constant).
    The backward pass needs no n×n product (see module docstring).
    """
    return _PosteriorSample.apply(cross, prior_variance, solve.detach(), noise.detach())


# ------------------------------------------------------------------- whitened (float32) form
# With Γ = L Lᵀ, the whitened cross-covariance v = L⁻¹ k* gives the mean vᵀβ (β = L⁻¹ y) and
# the quadratic ‖v‖². In float32, k* Γ⁻¹ k* through an explicit Γ⁻¹ loses everything to
# cancellation (error ~ ε cond(Γ) k**: measured on a cart-pole GP at n = 300, 44 % of the
# variances negative, median error 190×); v from a triangular solve is backward stable, so
# ‖v‖² errs by ~ √n ε k** typically (n ε k** at worst): on the same points 0.2 % median
# error and none negative. Below that precision a float32 variance is rounding noise, so
# it is floored there (:func:`precision_floor`): never negative, and ≥ the float64 value
# up to the floor. The forward pass is one triangular solve per output, the backward one
# more (∂/∂k* of the mean is α = L⁻ᵀβ, of ‖v‖² it is 2 L⁻ᵀ v): together the flops of the
# one [Γ⁻¹ | α] product of the inverse form.


def precision_floor(prior_variance: torch.Tensor, num_train: int) -> torch.Tensor:
    """Smallest posterior variance ``[G, M]`` a whitened computation in the prior's dtype
    resolves: √n ε k** (ε: the dtype's machine epsilon), and at least :data:`VARIANCE_FLOOR`."""
    epsilon = torch.finfo(prior_variance.dtype).eps
    return (prior_variance * (num_train**0.5 * epsilon)).clamp_min(VARIANCE_FLOOR)


def _whitened_products(
    cross: torch.Tensor, upper_factor: torch.Tensor, whitened_targets: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """v = L⁻¹ k* as rows ``[G, M, N]`` (v Lᵀ = k*; ``upper_factor`` Lᵀ, contiguous), mean
    vᵀβ and quadratic ‖v‖² ``[G, M]``."""
    whitened = torch.linalg.solve_triangular(upper_factor, cross, upper=True, left=False)
    mean = torch.linalg.vecdot(whitened, whitened_targets.unsqueeze(-2))
    return whitened, mean, whitened.square().sum(-1)


def _whitened_cross_gradient(
    whitened: torch.Tensor,
    factor: torch.Tensor,
    whitened_targets: torch.Tensor,
    grad_mean: torch.Tensor,
    grad_quadratic: torch.Tensor,
) -> torch.Tensor:
    """∂/∂k* ``[G, M, N]`` of Σ g_mean·mean + g_quad·‖v‖²: (g_mean β + 2 g_quad v) L⁻¹."""
    rows_t = whitened_targets.unsqueeze(-1) * grad_mean.unsqueeze(-2)  # [G, N, M]
    rows_t.addcmul_(whitened.mT, grad_quadratic.unsqueeze(-2), value=2.0)
    return torch.linalg.solve_triangular(factor, rows_t.mT, upper=False, left=False)


class _WhitenedPosteriorSample(torch.autograd.Function):
    @staticmethod
    def forward(
        ctx: Any,
        cross: torch.Tensor,
        prior_variance: torch.Tensor,
        factor: torch.Tensor,
        upper_factor: torch.Tensor,
        whitened_targets: torch.Tensor,
        noise: torch.Tensor,
    ) -> torch.Tensor:
        whitened, mean, quadratic = _whitened_products(cross, upper_factor, whitened_targets)
        variance = prior_variance - quadratic
        floor = precision_floor(prior_variance, factor.shape[-1])
        clamped = variance < floor
        std = torch.maximum(variance, floor).sqrt_()
        ctx.save_for_backward(whitened, factor, whitened_targets, noise, std, clamped)
        return torch.addcmul(mean, std, noise)

    @staticmethod
    @once_differentiable
    def backward(
        ctx: Any, grad: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, None, None, None, None]:
        whitened, factor, whitened_targets, noise, std, clamped = ctx.saved_tensors
        grad_variance = (grad * noise).div_(std).mul_(0.5).masked_fill_(clamped, 0.0)  # [G, M]
        grad_cross = _whitened_cross_gradient(
            whitened, factor, whitened_targets, grad, -grad_variance
        )
        return grad_cross, grad_variance, None, None, None, None


def whitened_posterior_sample(
    cross: torch.Tensor,
    prior_variance: torch.Tensor,
    factor: torch.Tensor,
    upper_factor: torch.Tensor,
    whitened_targets: torch.Tensor,
    noise: torch.Tensor,
) -> torch.Tensor:
    """:func:`posterior_sample` in the whitened form (for float32 rollouts).

    Args:
        cross: k(x*, X) ``[G, M, N]``. prior_variance: k(x*, x*) ``[G, M]``.
        factor: lower Cholesky factor L of Γ ``[G, N, N]``, contiguous (a constant; the
            backward solve's operand).
        upper_factor: Lᵀ, stored contiguous (the forward solve's operand): MKL's solve is
            ~6 % faster with it than with the transposed view of L (float32, N = 300,
            M = 400, one thread).
        whitened_targets: β = L⁻¹ y ``[G, N]`` (a constant).
        noise: standard normal ``[G, M]`` (constant).
    """
    return _WhitenedPosteriorSample.apply(
        cross,
        prior_variance,
        factor.detach(),
        upper_factor.detach(),
        whitened_targets.detach(),
        noise.detach(),
    )


def whitened_mean_and_quadratic(
    cross: torch.Tensor, upper_factor: torch.Tensor, whitened_targets: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    """``(k* α, diag(k* Γ⁻¹ k*ᵀ))`` ``[G, M]`` each, in the whitened form (plain autograd;
    the variance k** − quadratic is to be floored with :func:`precision_floor`)."""
    _, mean, quadratic = _whitened_products(cross, upper_factor.detach(), whitened_targets.detach())
    return mean, quadratic
