"""Moments of sines and cosines of Gaussian angles, and of PILCO's sine saturation."""

from __future__ import annotations

import torch


def trig_moments(
    mean: torch.Tensor, cov: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Exact moments of t = [sin a, cos a] for a ~ N(mean ``[n]``, cov ``[n, n]``).

    Uses E exp(i(a_j ± a_k)) = exp(i(μ_j ± μ_k) − ½(Σ_jj + Σ_kk ± 2Σ_jk)) and Stein's lemma
    for the cross-covariance.

    Returns:
        mean of t ``[2n]``; covariance of t ``[2n, 2n]``; ``C`` ``[n, 2n]`` with
        Cov(y, t) = Cov(y, a) C for any y jointly Gaussian with a.
    """
    variance = torch.diagonal(cov)
    damp = torch.exp(-0.5 * variance)
    sin_mean, cos_mean = damp * torch.sin(mean), damp * torch.cos(mean)
    var_sum = variance[:, None] + variance[None, :]
    minus = torch.exp(-0.5 * (var_sum - 2.0 * cov))  # |E e^{i(a_j - a_k)}|
    plus = torch.exp(-0.5 * (var_sum + 2.0 * cov))  # |E e^{i(a_j + a_k)}|
    diff = mean[:, None] - mean[None, :]
    total = mean[:, None] + mean[None, :]
    cos_diff, cos_total = minus * torch.cos(diff), plus * torch.cos(total)
    sin_diff, sin_total = minus * torch.sin(diff), plus * torch.sin(total)
    sin_sin = 0.5 * (cos_diff - cos_total) - torch.outer(sin_mean, sin_mean)
    cos_cos = 0.5 * (cos_diff + cos_total) - torch.outer(cos_mean, cos_mean)
    sin_cos = 0.5 * (sin_total + sin_diff) - torch.outer(sin_mean, cos_mean)  # sin a_j cos a_k
    covariance = torch.cat(
        [torch.cat([sin_sin, sin_cos], dim=1), torch.cat([sin_cos.T, cos_cos], dim=1)], dim=0
    )
    stein = torch.cat([torch.diag(cos_mean), torch.diag(-sin_mean)], dim=1)
    return torch.cat([sin_mean, cos_mean]), covariance, stein


def sine_saturation(
    mean: torch.Tensor, cov: torch.Tensor, u_max: float
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Moments of PILCO's saturation u = u_max (9 sin z + sin 3z)/8 (elementwise; |u| ≤ u_max,
    u = u_max at z = π/2) for z ~ N(mean ``[d]``, cov ``[d, d]``).

    Returns:
        mean ``[d]``, covariance ``[d, d]`` of u, and ``C`` ``[d, d]`` with
        Cov(y, u) = Cov(y, z) C.
    """
    dim = mean.shape[0]
    eye = torch.eye(dim, dtype=mean.dtype, device=mean.device)
    spread = torch.cat([eye, 3.0 * eye], dim=0)  # a = [z, 3z]
    combine = (u_max / 8.0) * torch.cat([9.0 * eye, eye], dim=1)  # u = combine · sin a
    trig_mean, trig_cov, stein = trig_moments(spread @ mean, spread @ cov @ spread.T)
    sin_mean, sin_cov = trig_mean[: 2 * dim], trig_cov[: 2 * dim, : 2 * dim]
    sin_stein = stein[:, : 2 * dim]  # Cov(a, sin a) = Cov(a, a) · sin_stein
    out_cov = combine @ sin_cov @ combine.T
    return combine @ sin_mean, 0.5 * (out_cov + out_cov.T), spread.T @ sin_stein @ combine.T


def sine_saturate(values: torch.Tensor, u_max: float) -> torch.Tensor:
    """u_max (9 sin z + sin 3z)/8 of pre-saturation values z (any shape)."""
    return (u_max / 8.0) * (9.0 * torch.sin(values) + torch.sin(3.0 * values))
