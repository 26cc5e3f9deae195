"""Closed-form moment matching (PILCO) against Monte Carlo and closed forms."""

from __future__ import annotations

import math

import pytest
import torch

from mcpilco.costs.quadratic import SaturatingQuadratic
from mcpilco.moments import rbf_moments, sine_saturation, trig_moments
from mcpilco.moments.trig import sine_saturate
from mcpilco.policies.rbf import SquashedRBFPolicy

F64 = torch.float64
SAMPLES = 200_000


def gaussian(dim: int, seed: int, scale: float = 0.4) -> tuple[torch.Tensor, torch.Tensor]:
    g = torch.Generator().manual_seed(seed)
    mean = torch.randn(dim, generator=g, dtype=F64) * 0.5
    root = torch.randn(dim, dim, generator=g, dtype=F64) * scale
    return mean, root @ root.T + 0.05 * torch.eye(dim, dtype=F64)


def samples(mean: torch.Tensor, cov: torch.Tensor, seed: int = 1) -> torch.Tensor:
    g = torch.Generator().manual_seed(seed)
    z = torch.randn(SAMPLES, mean.shape[0], generator=g, dtype=F64)
    return mean + z @ torch.linalg.cholesky(cov).T


def cross(x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
    return (x - x.mean(0)).T @ (y - y.mean(0)) / x.shape[0]


def test_trig_moments_match_monte_carlo() -> None:
    mean, cov = gaussian(3, 0)
    x = samples(mean, cov)
    t = torch.cat([x.sin(), x.cos()], dim=1)
    t_mean, t_cov, stein = trig_moments(mean, cov)
    assert torch.allclose(t_mean, t.mean(0), atol=4e-3)
    assert torch.allclose(t_cov, torch.cov(t.T), atol=4e-3)
    assert torch.allclose(cov @ stein, cross(x, t), atol=4e-3)


def test_sine_saturation_matches_monte_carlo() -> None:
    mean, cov = gaussian(2, 1, scale=0.8)
    z = samples(mean, cov)
    u = sine_saturate(z, 10.0)
    u_mean, u_cov, factor = sine_saturation(mean, cov, 10.0)
    assert torch.allclose(u_mean, u.mean(0), atol=0.03)
    assert torch.allclose(u_cov, torch.cov(u.T), rtol=0.01, atol=0.05)
    assert torch.allclose(cov @ factor, cross(z, u), atol=0.03)
    assert float(u.abs().max()) <= 10.0 + 1e-9


def test_rbf_moments_match_monte_carlo_with_gp_variance() -> None:
    """Mean, covariance (incl. the GP's posterior variance term) and input-output
    covariance of two SE-kernel GP posteriors at a Gaussian input."""
    g = torch.Generator().manual_seed(2)
    n, d = 12, 3
    inputs = torch.randn(n, d, generator=g, dtype=F64)
    lengthscales = torch.tensor([[0.8, 1.2, 1.0], [1.5, 0.7, 0.9]], dtype=F64)
    variances = torch.tensor([1.3, 0.6], dtype=F64)
    noise = 0.1

    def kernel(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:  # [E, len(a), len(b)]
        diff = (a[None, :, None, :] - b[None, None, :, :]) / lengthscales[:, None, None, :]
        return variances[:, None, None] * torch.exp(-0.5 * diff.square().sum(-1))

    targets = torch.randn(2, n, generator=g, dtype=F64)
    gram = kernel(inputs, inputs) + noise**2 * torch.eye(n, dtype=F64)
    inverse = torch.linalg.inv(gram)
    beta = (inverse @ targets[..., None])[..., 0]
    mean, cov = gaussian(d, 3)
    out_mean, out_cov, factor = rbf_moments(
        inputs, beta, 1.0 / lengthscales**2, variances, mean, cov, inverse
    )
    # Monte Carlo of f(x) ~ GP posterior at x ~ N(mean, cov): f = μ(x) + σ(x) ε
    x = samples(mean, cov)[:50_000]
    k = kernel(x, inputs)  # [E, S, N]
    post_mean = (k * beta[:, None, :]).sum(-1).T  # [S, E]
    post_var = variances[None] - torch.einsum("esn,enm,esm->se", k, inverse, k)
    eps = torch.randn(x.shape[0], 2, generator=g, dtype=F64)
    f = post_mean + post_var.clamp_min(0).sqrt() * eps
    assert torch.allclose(out_mean, f.mean(0), atol=0.02)
    assert torch.allclose(out_cov, torch.cov(f.T), rtol=0.03, atol=0.01)
    assert torch.allclose(cov @ factor, cross(x, post_mean), atol=0.01)


def test_rbf_moments_gradient_matches_finite_differences() -> None:
    g = torch.Generator().manual_seed(4)
    inputs = torch.randn(6, 2, generator=g, dtype=F64)
    beta = torch.randn(2, 6, generator=g, dtype=F64)
    inverse_lambda = torch.tensor([[1.0, 2.0], [0.5, 1.5]], dtype=F64)
    variances = torch.tensor([1.0, 0.5], dtype=F64)
    inverse_gram = torch.eye(6, dtype=F64).expand(2, 6, 6) * 0.3
    mean, cov = gaussian(2, 5)

    def function(m: torch.Tensor, s: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
        s = 0.5 * (s + s.T)
        out_mean, out_cov, factor = rbf_moments(
            inputs, b, inverse_lambda, variances, m, s, inverse_gram
        )
        return torch.cat([out_mean, out_cov.flatten(), factor.flatten()])

    assert torch.autograd.gradcheck(
        function, (mean.requires_grad_(), cov.requires_grad_(), beta.requires_grad_())
    )


@pytest.mark.parametrize("length,width", [(0.5, 0.25), (0.3, 1.0)])
def test_expected_saturating_cost_equals_closed_form(length: float, width: float) -> None:
    """1-D: E[1 − exp(−½ (x − t)²/w²)] = 1 − w/√(w² + σ²) exp(−½ (μ − t)²/(w² + σ²))."""
    cost = SaturatingQuadratic(angles=[], projection=[[1.0, 0.0]], offset=[0.4], width=width)
    mean = torch.tensor([0.1, 3.0], dtype=F64)
    cov = torch.tensor([[length**2, 0.1], [0.1, 2.0]], dtype=F64)
    closed = 1 - width / math.sqrt(width**2 + length**2) * math.exp(
        -0.5 * (0.1 - 0.4) ** 2 / (width**2 + length**2)
    )
    assert float(cost.expected_gaussian(mean, cov)) == pytest.approx(closed, rel=1e-12)


def test_expected_cartpole_cost_matches_monte_carlo() -> None:
    """PILCO's cart-pole cost (2.17) with the sines and cosines of θ moment matched: close to
    the Monte Carlo mean for a moderately spread state (exact for a point mass)."""
    cost = SaturatingQuadratic(
        angles=[2],
        projection=[[1, 0, 0, 0, 0.5, 0], [0, 0, 0, 0, 0, 0.5]],
        offset=[0.0, -0.5],
        width=0.25,
    )
    mean = torch.tensor([0.05, 0.0, 2.9, 0.0], dtype=F64)
    cov = torch.diag(torch.tensor([0.01, 0.1, 0.02, 0.1], dtype=F64))
    x = samples(mean, cov)
    p, theta = x[:, 0], x[:, 2]
    d2 = p**2 + 2 * p * 0.5 * theta.sin() + 2 * 0.25 * (1 + theta.cos())
    monte_carlo = (1 - torch.exp(-0.5 * d2 / 0.25**2)).mean()
    assert torch.allclose(cost(x).mean(), monte_carlo)  # the particle form is (2.17)
    assert float(cost.expected_gaussian(mean, cov)) == pytest.approx(float(monte_carlo), abs=0.02)
    point = torch.zeros(4, 4, dtype=F64) + 1e-14 * torch.eye(4, dtype=F64)
    assert float(cost.expected_gaussian(mean, point)) == pytest.approx(float(cost(mean)), abs=1e-9)


def test_sine_rbf_policy_moments_match_monte_carlo() -> None:
    policy = SquashedRBFPolicy(
        3,
        2,
        u_max=5.0,
        num_basis=10,
        lengthscale=1.0,
        centre_range=1.5,
        squash="sine",
        generator=torch.Generator().manual_seed(6),
    )
    mean, cov = gaussian(3, 7)
    x = samples(mean, cov)
    with torch.no_grad():
        u = policy(x)
        u_mean, u_cov, factor = policy.gaussian_moments(mean, cov)
    assert torch.allclose(u_mean, u.mean(0), atol=0.02)
    assert torch.allclose(u_cov, torch.cov(u.T), rtol=0.02, atol=0.02)
    assert torch.allclose(cov @ factor, cross(x, u), atol=0.02)


def test_tanh_policy_has_no_moments() -> None:
    policy = SquashedRBFPolicy(2, 1, u_max=1.0, num_basis=3)
    with pytest.raises(Exception, match="policy.squash=sine"):
        policy.gaussian_moments(torch.zeros(2, dtype=F64), torch.eye(2, dtype=F64))


@pytest.mark.parametrize("squash", ["tanh", "sine"])
def test_population_act_equals_each_policy(squash: str) -> None:
    policy = SquashedRBFPolicy(
        3, 2, u_max=4.0, num_basis=7, squash=squash, generator=torch.Generator().manual_seed(0)
    )
    vectors = torch.randn(5, sum(p.numel() for p in policy.parameters()), dtype=F64)
    inputs = torch.randn(5 * 11, 3, dtype=F64)
    with torch.no_grad():
        batched = policy.population_act(vectors)(inputs).view(5, 11, 2)
        for p in range(5):
            torch.nn.utils.vector_to_parameters(vectors[p], policy.parameters())
            assert torch.allclose(batched[p], policy(inputs[p * 11 : (p + 1) * 11]))
