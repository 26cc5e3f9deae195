"""Exact GP against closed forms computed independently with numpy/scipy."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy.stats import multivariate_normal

from mcpilco.errors import NotPositiveDefiniteError
from mcpilco.gp import ExactGP, MarginalLikelihoodFit, cholesky_with_jitter, reduce_dataset
from mcpilco.kernels import KernelShape, SquaredExponential


def numpy_se(a: np.ndarray, b: np.ndarray, lengthscale: np.ndarray, variance: float) -> np.ndarray:
    diff = (a[:, None, :] - b[None, :, :]) / lengthscale
    return variance * np.exp(-(diff**2).sum(-1))


def make_gp(outputs: int = 2, dim: int = 3) -> tuple[ExactGP, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    x = rng.normal(size=(25, dim))
    y = np.stack([np.sin(x[:, 0]) + 0.1 * x[:, 1], np.cos(x[:, 2])], 1)[:, :outputs]
    kernel = SquaredExponential(
        KernelShape(outputs, dim), lengthscale=[0.7, 1.3, 2.0], variance=1.5
    )
    gp = ExactGP(kernel, noise_std=0.2)
    gp.set_data(torch.as_tensor(x), torch.as_tensor(y))
    return gp, x, y


def test_posterior_matches_numpy_closed_form() -> None:
    gp, x, y = make_gp()
    x_test = np.random.default_rng(1).normal(size=(7, 3))
    mean, variance = gp.predict(torch.as_tensor(x_test))
    lengthscale, noise = np.array([0.7, 1.3, 2.0]), gp.noise_variance.detach().numpy()
    for g in range(2):
        gram = numpy_se(x, x, lengthscale, 1.5) + noise[g] * np.eye(len(x))
        cross = numpy_se(x_test, x, lengthscale, 1.5)
        expected_mean = cross @ np.linalg.solve(gram, y[:, g])
        expected_var = 1.5 - np.einsum("ij,ji->i", cross, np.linalg.solve(gram, cross.T))
        np.testing.assert_allclose(mean[g].detach().numpy(), expected_mean, rtol=1e-9, atol=1e-10)
        np.testing.assert_allclose(
            variance[g].detach().numpy(), expected_var, rtol=1e-8, atol=1e-10
        )


def test_sample_is_mean_plus_std_times_noise(generator: torch.Generator) -> None:
    gp, _, _ = make_gp()
    x_test = torch.randn(9, 3, generator=generator, dtype=torch.float64)
    noise = torch.randn(2, 9, generator=generator, dtype=torch.float64)
    mean, variance = gp.predict(x_test)
    torch.testing.assert_close(gp.sample(x_test, noise), mean + variance.sqrt() * noise)


def test_marginal_likelihood_matches_scipy() -> None:
    gp, x, y = make_gp()
    noise = gp.noise_variance.detach().numpy()
    expected = 0.0
    for g in range(2):
        cov = numpy_se(x, x, np.array([0.7, 1.3, 2.0]), 1.5) + noise[g] * np.eye(len(x))
        expected -= multivariate_normal(np.zeros(len(x)), cov).logpdf(y[:, g])
    got = float(gp.negative_log_marginal_likelihood().detach()) * len(x)
    assert got == pytest.approx(expected, rel=1e-10)


def test_fit_improves_likelihood_and_beats_adam_recipe() -> None:
    gp, _, _ = make_gp()
    before = float(gp.negative_log_marginal_likelihood().detach())
    after = MarginalLikelihoodFit(max_iterations=100)(gp)
    assert after < before
    reference, _, _ = make_gp()
    adam = torch.optim.Adam(reference.parameters(), lr=0.01)
    for _ in range(300):
        adam.zero_grad()
        reference.negative_log_marginal_likelihood().backward()
        adam.step()
    assert after <= float(reference.negative_log_marginal_likelihood().detach()) + 1e-6


def test_cholesky_adds_jitter_then_fails_with_named_error() -> None:
    singular = torch.ones(1, 4, 4, dtype=torch.float64)  # rank one, PSD
    factor = cholesky_with_jitter(singular, "GP outputs ['a']")
    assert torch.all(torch.isfinite(factor))
    broken = torch.full((1, 3, 3), float("nan"), dtype=torch.float64)
    with pytest.raises(NotPositiveDefiniteError, match=r"GP outputs \['a'\]"):
        cholesky_with_jitter(broken, "GP outputs ['a']")


def test_reduction_keeps_exactly_the_uncertain_samples() -> None:
    gp, x, y = make_gp(outputs=1, dim=3)
    MarginalLikelihoodFit(max_iterations=50)(gp)
    threshold = 0.05
    # Independent greedy reference: recompute each posterior std from scratch.
    full_inputs = gp.train_inputs.clone()
    kept: list[int] = [0]
    for i in range(1, len(x)):
        probe = ExactGP(gp.kernel, noise_std=0.5)
        probe.raw_noise = gp.raw_noise
        probe.set_data(full_inputs[kept], gp.train_targets[kept])
        _, variance = probe.predict(full_inputs[i : i + 1])
        if float(variance.max()) > threshold**2:
            kept.append(i)
    index = reduce_dataset(gp, threshold)
    assert index.tolist() == kept
    assert gp.train_inputs.shape[0] == len(kept) < len(x)


@pytest.mark.parametrize(("std_over_threshold", "expected"), [(1.2, 25), (0.8, 1)])
def test_a_white_noise_like_se_term_above_threshold_keeps_every_sample(
    std_over_threshold: float, expected: int
) -> None:
    """The UR5 DF trial-3 fit (docs/results/ur5_df/): an SE term with length-scales ~1e-7
    has zero covariance between distinct samples, so its variance is latent variance left
    at every sample whatever is kept: above β² every sample stays, below it only the first.
    The probe's per-output LU recount agrees with the incremental Cholesky."""
    from analysis.reduction_probe import greedy_kept

    threshold = 1e-3
    gp, _, _ = make_gp(outputs=1)
    gp.kernel = SquaredExponential(
        KernelShape(1, 3), lengthscale=1e-7, variance=(std_over_threshold * threshold) ** 2
    ).double()
    with torch.no_grad():
        gp.raw_noise.fill_(-30.0)  # noise at its floor, as in the UR5 fit
        gram = gp.kernel(gp.train_inputs, gp.train_inputs)[0]
    assert float((gram - torch.diag(torch.diagonal(gram))).abs().max()) == 0.0
    recount = greedy_kept(gram, float(gp.noise_variance.detach()[0]), threshold)
    assert recount == expected == len(reduce_dataset(gp, threshold))


def test_fused_prediction_gradients(generator: torch.Generator) -> None:
    from mcpilco.gp.prediction import mean_and_quadratic, posterior_sample, solve_matrix

    dtype = torch.float64
    cross = (0.3 * torch.rand(2, 6, 4, generator=generator, dtype=dtype)).requires_grad_()
    a = torch.randn(2, 4, 4, generator=generator, dtype=dtype)
    inverse_gram = a @ a.transpose(-1, -2) + torch.eye(4, dtype=dtype)
    alpha = torch.randn(2, 4, generator=generator, dtype=dtype)
    prior = torch.full((2, 6), 5.0, dtype=dtype, requires_grad=True)
    noise = torch.randn(2, 6, generator=generator, dtype=dtype)
    assert torch.autograd.gradcheck(
        lambda k, p: posterior_sample(k, p, solve_matrix(inverse_gram, alpha), noise),
        (cross, prior),
    )
    assert torch.autograd.gradcheck(
        lambda k: mean_and_quadratic(k, solve_matrix(inverse_gram, alpha)), (cross,)
    )
