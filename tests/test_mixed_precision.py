"""The mixed setting (``rollout_dtype=float32``): float64 GP, float32 particle rollout."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch
from hydra import compose, initialize_config_dir

from mcpilco.build import build
from mcpilco.errors import ConfigError
from mcpilco.gp import ExactGP
from mcpilco.gp.prediction import precision_floor
from mcpilco.kernels import KernelShape, SquaredExponential
from mcpilco.optim.policy_optimizer import frozen
from mcpilco.optim.rollout import ParticleRollout
from runners.bench import exploration_data

CONFIG_DIR = str(Path(__file__).resolve().parent.parent / "conf")


def ill_conditioned_gp(noise_std: float = 1e-2) -> tuple[ExactGP, np.ndarray, np.ndarray]:
    """120 points 0.025 apart on a length-scale of 1, signal variance 1: with noise std
    1e-2 the signal-to-noise ratio of the cart-pole's GPs (σ_f²/σ_n² ~ 1e4), cond(Γ) ~ 1e6."""
    x = np.linspace(0.0, 3.0, 120)[:, None]
    y = np.sin(2.0 * x)
    kernel = SquaredExponential(KernelShape(1, 1), lengthscale=1.0, variance=1.0)
    gp = ExactGP(kernel, noise_std=noise_std, noise_std_min=1e-5)
    gp.set_data(torch.as_tensor(x), torch.as_tensor(y))
    return gp, x, y


def numpy_posterior_variance(x: np.ndarray, x_test: np.ndarray, noise: float) -> np.ndarray:
    """Latent variance k** − k*ᵀ Γ⁻¹ k* in float64 numpy (the reference)."""
    gram = np.exp(-((x - x.T) ** 2)) + noise * np.eye(len(x))
    cross = np.exp(-((x_test - x.T) ** 2))
    return 1.0 - np.einsum("ij,ji->i", cross, np.linalg.solve(gram, cross.T))


@pytest.mark.parametrize("noise_std", [1e-2, 1e-3])
def test_float32_variance_stays_positive_where_the_plain_formula_goes_negative(
    noise_std: float,
) -> None:
    """Plain float32 k** − k*ᵀ Γ⁻¹ k* (Γ⁻¹ from float64, rounded) goes negative beside the
    data (measured: down to −0.004 at noise 1e-2, −0.4 at 1e-3, against a prior of 1); the
    whitened form is accurate to its precision floor √n ε k** (1.3e-6 here) and never below
    it: at noise 1e-2 (true variances 6e-6..4e-5) within 5 % (median; measured 1.7 %), at
    1e-3 (true 7e-8..5e-7, below what float32 resolves) at the floor."""
    gp, x, _ = ill_conditioned_gp(noise_std)
    x_test = x[::3] + 0.004  # beside the data, where the variance is smallest
    expected = numpy_posterior_variance(x, x_test, float(gp.noise_variance.detach()))
    assert expected.min() > 0 and expected.max() < 1e-4  # tiny next to the prior's 1

    inverse_gram, _ = gp.posterior_weights()
    cross32 = torch.exp(-((torch.as_tensor(x_test) - torch.as_tensor(x).T) ** 2)).float()
    plain = 1.0 - torch.einsum("mn,nk,mk->m", cross32, inverse_gram[0].float(), cross32)
    assert (plain < 0).any()

    _, variance = gp.predict(torch.as_tensor(x_test, dtype=torch.float32))
    assert variance.dtype == torch.float32
    got = variance[0].double().numpy()
    floor = float(precision_floor(torch.ones(1, dtype=torch.float32), len(x)))
    assert floor == pytest.approx(120**0.5 * torch.finfo(torch.float32).eps)
    assert got.min() >= floor * (1 - 1e-6)
    assert np.abs(got - expected).max() <= 2 * floor
    if noise_std == 1e-2:
        assert np.median(np.abs(got / expected - 1.0)) < 0.05

    # the reparameterised sample's std is the same floored variance's square root
    noise = torch.ones(1, x_test.shape[0])
    mean, _ = gp.predict(torch.as_tensor(x_test, dtype=torch.float32))
    sample = gp.sample(torch.as_tensor(x_test, dtype=torch.float32), noise)
    torch.testing.assert_close(sample - mean, variance.sqrt(), rtol=1e-4, atol=1e-7)


def test_float32_mean_and_sample_match_float64_on_the_same_gp() -> None:
    gp, x, _ = ill_conditioned_gp()
    x_test = torch.as_tensor(x[::4] + 0.3)
    mean64, variance64 = gp.predict(x_test)
    mean32, variance32 = gp.predict(x_test.float())
    torch.testing.assert_close(mean32.double(), mean64, rtol=1e-4, atol=1e-5)
    noise = torch.randn(1, x_test.shape[0], generator=torch.Generator().manual_seed(0))
    sample32 = gp.sample(x_test.float(), noise.float())
    torch.testing.assert_close(
        sample32.double(), mean64 + variance64.sqrt() * noise.double(), rtol=1e-3, atol=1e-4
    )


def cartpole(*overrides: str):  # type: ignore[no-untyped-def]
    with initialize_config_dir(version_base="1.3", config_dir=CONFIG_DIR):
        cfg = compose("train", overrides=["compile=false", *overrides])
    return build(cfg)


def cost_and_gradient(rollout: ParticleRollout, particles: int) -> tuple[float, torch.Tensor]:
    rollout.policy.zero_grad()
    with frozen(rollout.model):
        result = rollout(particles, 0.25, torch.Generator().manual_seed(5))
        result.total_cost.backward()
    assert result.states.dtype == torch.float64  # handed back in the model's dtype
    gradient = torch.cat([p.grad.flatten() for p in rollout.policy.parameters()])  # type: ignore[union-attr]
    return float(result.total_cost.detach()), gradient


@pytest.mark.parametrize("kernel", ["se", "sp"])
def test_mixed_rollout_agrees_with_float64_on_the_same_random_numbers(kernel: str) -> None:
    """Same draws (made in float64 and cast), 100 particles over the whole 3-s trial with
    dropout: Ĵ within 0.2 % and the policy gradient within 2 % (norm of the difference;
    measured 4e-6..8e-4 and 1e-4..7e-3 at n = 60..300). The float32 rollout is the only
    difference: the GP is the same float64 fit."""
    built = cartpole(f"kernel={kernel}")
    c = built.components
    states, actions = exploration_data(built, 100)
    c.model.fit(states, actions)
    args = (c.system, c.model, c.policy, c.cost, c.estimator)
    cost64, gradient64 = cost_and_gradient(ParticleRollout.for_system(*args), 100)
    mixed = ParticleRollout.for_system(*args, dtype=torch.float32)
    cost32, gradient32 = cost_and_gradient(mixed, 100)
    assert mixed.stepping_model() is not c.model  # the particles went through the twin
    assert all(p.dtype == torch.float64 for p in c.policy.parameters())
    assert cost32 == pytest.approx(cost64, rel=2e-3)
    assert float((gradient32 - gradient64).norm() / gradient64.norm()) < 2e-2


def test_mixed_twin_follows_refits_and_keeps_the_model_in_float64() -> None:
    built = cartpole("rollout_dtype=float32")
    c = built.components
    assert c.rollout_dtype == torch.float32
    states, actions = exploration_data(built, 40)
    c.model.fit(states, actions)
    rollout = ParticleRollout.for_system(
        c.system, c.model, c.policy, c.cost, c.estimator, dtype=c.rollout_dtype
    )
    twin = rollout.stepping_model()
    assert twin.gp is c.model.gp and twin.state_map.dtype == torch.float32
    assert c.model.state_map.dtype == torch.float64
    c.model.fit(*exploration_data(built, 60, seed=3))
    assert rollout.stepping_model() is twin and twin.gp is c.model.gp  # one object, new GP
    assert c.model.gp is not None and c.model.gp.train_inputs.dtype == torch.float64


def test_a_bad_rollout_dtype_is_refused_before_any_work() -> None:
    with pytest.raises(ConfigError, match="rollout_dtype='float16'"):
        cartpole("rollout_dtype=float16")


def test_a_gp_out_of_float32_range_is_rolled_out_in_float64_with_a_warning(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A float64 fit may leave a term with length-scale 1e-46 and variance 1e-101 (measured
    on a UR5 DF model): its inverse length-scale overflows float32 and every prediction
    would be NaN. That GP is rolled out in float64 until the next fit."""
    built = cartpole("rollout_dtype=float32")
    c = built.components
    c.model.fit(*exploration_data(built, 40))
    assert c.model.gp is not None
    with torch.no_grad():
        c.model.gp.kernel.log_lengthscale[0, 0] = -105.0
        c.model.gp.kernel.log_variance[0] = -233.0
    c.model.gp.precompute()
    assert not c.model.gp.predicts_in(torch.float32)
    rollout = ParticleRollout.for_system(
        c.system, c.model, c.policy, c.cost, c.estimator, dtype=c.rollout_dtype
    )
    with caplog.at_level("WARNING"):
        cost, gradient = cost_and_gradient(rollout, 50)
    assert "not finite in torch.float32" in caplog.text
    assert rollout.dtype == torch.float64 and rollout.stepping_model() is c.model
    assert np.isfinite(cost) and bool(torch.isfinite(gradient).all())
    c.model.fit(*exploration_data(built, 40))  # a new fit: float32 again
    assert rollout.stepping_model() is not c.model and rollout.dtype == torch.float32
