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


def numpy_greedy(x: np.ndarray, noise: np.ndarray, std_limits: np.ndarray) -> list[int]:
    """The greedy rule recomputed from scratch with numpy: keep sample i when any output's
    latent posterior std, given the samples kept so far, exceeds that output's limit."""
    lengthscale = np.array([0.7, 1.3, 2.0])
    kept = [0]
    for i in range(1, len(x)):
        subset = x[kept]
        gram = numpy_se(subset, subset, lengthscale, 1.5)
        cross = numpy_se(subset, x[i : i + 1], lengthscale, 1.5)[:, 0]
        for g in range(len(noise)):
            latent = 1.5 - cross @ np.linalg.solve(gram + noise[g] * np.eye(len(kept)), cross)
            if latent > std_limits[g] ** 2:
                kept.append(i)
                break
    return kept


def test_relative_reduction_uses_each_outputs_noise_std() -> None:
    """``mode="relative"`` (the reference code's SoD): output g keeps a sample when its latent
    std exceeds β σ_n[g]; the set differs from an absolute β at either output's σ_n."""
    beta, noise_std = 5.0, np.array([0.1, 0.5])  # limits 0.5 and 2.5 (above the prior std 1.22)
    x = make_gp()[1]
    kept = {}
    for mode, threshold in [("relative", beta), ("absolute", beta * 0.1), ("absolute", beta * 0.5)]:
        gp = make_gp()[0]
        with torch.no_grad():
            gp.raw_noise.copy_(torch.as_tensor(np.log(noise_std**2 - gp.noise_variance_min)))
        kept[mode, threshold] = reduce_dataset(gp, threshold, mode).tolist()
        assert gp.train_inputs.shape[0] == len(kept[mode, threshold])
    assert kept["relative", beta] == numpy_greedy(x, noise_std**2, beta * noise_std)
    assert kept["absolute", beta * 0.1] == numpy_greedy(x, noise_std**2, np.full(2, beta * 0.1))
    # absolute 0.5: output 1 (the larger noise leaves it the larger latent std) keeps every
    # sample; relative gives output 1 a limit above its prior std, so output 0 alone decides
    assert len(kept["relative", beta]) < len(kept["absolute", beta * 0.1]) == 25
    assert kept["absolute", beta * 0.5] == [0]


@pytest.mark.parametrize(
    ("threshold", "mode", "message"),
    [
        (0.5, "rel", "model.reduction_mode must be one of ['absolute', 'relative'], got 'rel'"),
        (-1.0, "absolute", "model.reduction_threshold must be > 0 or null, got -1.0"),
        ("0.5", "relative", "model.reduction_threshold must be > 0 or null, got '0.5'"),
    ],
)
def test_reduction_settings_are_checked(threshold: object, mode: str, message: str) -> None:
    from mcpilco.errors import ConfigError
    from mcpilco.gp.reduction import check_reduction

    with pytest.raises(ConfigError) as error:
        check_reduction(threshold, mode)  # type: ignore[arg-type]
    assert str(error.value) == message


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
