"""GP predictive mean and variance with a hand-written gradient.

For a fixed training set, the predictive mean and the data-dependent part of the variance
of test inputs are functions of the cross-covariances k* = k(x*, X) only:

    mean = k* α,    quad = k* Γ⁻¹ k*ᵀ (its diagonal),    α = Γ⁻¹ y.

Autograd would spend a second n×n product per particle in the backward pass; the gradient
is known in closed form (∂mean/∂k* = α, ∂quad/∂k* = 2 Γ⁻¹ k*), and Γ⁻¹ k* is already
computed in the forward pass, so the backward pass needs no matrix product at all.
"""

from __future__ import annotations

from typing import Any

import torch
from torch.autograd.function import once_differentiable


def _products(
    cross: torch.Tensor, inverse_gram: torch.Tensor, alpha: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Γ⁻¹ k* ``[G, M, N]``, mean k* α ``[G, M]`` and quadratic k* Γ⁻¹ k*ᵀ ``[G, M]``."""
    weighted = torch.matmul(cross, inverse_gram)
    mean = torch.matmul(cross, alpha.unsqueeze(-1)).squeeze(-1)
    return weighted, mean, torch.linalg.vecdot(weighted, cross)


def _cross_gradient(
    weighted: torch.Tensor,
    alpha: torch.Tensor,
    grad_mean: torch.Tensor,
    grad_quadratic: torch.Tensor,
) -> torch.Tensor:
    """∂/∂k* of the mean is α, of the quadratic 2 Γ⁻¹ k*."""
    grad_cross = weighted * (2.0 * grad_quadratic).unsqueeze(-1)
    return grad_cross.add_(grad_mean.unsqueeze(-1) * alpha.unsqueeze(-2))


class _MeanAndQuadratic(torch.autograd.Function):
    @staticmethod
    def forward(
        ctx: Any, cross: torch.Tensor, inverse_gram: torch.Tensor, alpha: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        weighted, mean, quadratic = _products(cross, inverse_gram, alpha)
        ctx.save_for_backward(weighted, alpha)
        return mean, quadratic

    @staticmethod
    @once_differentiable
    def backward(
        ctx: Any, grad_mean: torch.Tensor, grad_quadratic: torch.Tensor
    ) -> tuple[torch.Tensor, None, None]:
        weighted, alpha = ctx.saved_tensors
        return _cross_gradient(weighted, alpha, grad_mean, grad_quadratic), None, None


def mean_and_quadratic(
    cross: torch.Tensor, inverse_gram: torch.Tensor, alpha: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    """``(k* α, diag(k* Γ⁻¹ k*ᵀ))``, each ``[G, M]``.

    Args:
        cross: k(x*, X) ``[G, M, N]`` (may require grad).
        inverse_gram: Γ⁻¹ = (K + σ²I)⁻¹ ``[G, N, N]``, treated as a constant.
        alpha: Γ⁻¹ y ``[G, N]``, treated as a constant.
    """
    return _MeanAndQuadratic.apply(cross, inverse_gram.detach(), alpha.detach())


VARIANCE_FLOOR = 1e-12
"""Posterior variances below this are clamped (their gradient is then zero)."""


class _PosteriorSample(torch.autograd.Function):
    @staticmethod
    def forward(
        ctx: Any,
        cross: torch.Tensor,
        prior_variance: torch.Tensor,
        inverse_gram: torch.Tensor,
        alpha: torch.Tensor,
        noise: torch.Tensor,
    ) -> torch.Tensor:
        weighted, mean, quadratic = _products(cross, inverse_gram, alpha)
        variance = prior_variance - quadratic
        clamped = variance < VARIANCE_FLOOR
        std = variance.clamp_min(VARIANCE_FLOOR).sqrt_()
        ctx.save_for_backward(weighted, alpha, noise, std, clamped)
        return torch.addcmul(mean, std, noise)

    @staticmethod
    @once_differentiable
    def backward(
        ctx: Any, grad: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, None, None, None]:
        weighted, alpha, noise, std, clamped = ctx.saved_tensors
        grad_variance = (grad * noise / (2.0 * std)).masked_fill_(clamped, 0.0)  # [G, M]
        grad_cross = _cross_gradient(weighted, alpha, grad, -grad_variance)
        return grad_cross, grad_variance, None, None, None


def posterior_sample(
    cross: torch.Tensor,
    prior_variance: torch.Tensor,
    inverse_gram: torch.Tensor,
    alpha: torch.Tensor,
    noise: torch.Tensor,
) -> torch.Tensor:
    """Reparameterised sample mean + std ⊙ noise of the latent posterior, ``[G, M]``.

    Args:
        cross: k(x*, X) ``[G, M, N]``. prior_variance: k(x*, x*) ``[G, M]``.
        inverse_gram: Γ⁻¹ ``[G, N, N]`` and alpha: Γ⁻¹ y ``[G, N]`` (constants).
        noise: standard normal ``[G, M]`` (constant).
    The backward pass needs no n×n product (see module docstring).
    """
    return _PosteriorSample.apply(
        cross, prior_variance, inverse_gram.detach(), alpha.detach(), noise.detach()
    )
