"""PILCO's moment-matched propagation against Monte Carlo, its gradient against finite
differences, and the algorithm's refusals."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import pytest
import torch
from hydra import compose, initialize_config_dir

from mcpilco.build import build
from mcpilco.costs.quadratic import SaturatingQuadratic
from mcpilco.errors import ConfigError
from mcpilco.gp.exact import ExactGP
from mcpilco.gp.fit import MarginalLikelihoodFit
from mcpilco.kernels.base import KernelShape
from mcpilco.kernels.se import SquaredExponential
from mcpilco.models.features import AngleFeatures
from mcpilco.moments.propagation import MomentMatchingRollout

F64 = torch.float64
CONFIG_DIR = Path(__file__).resolve().parent.parent / "conf"


class LinearPolicy(torch.nn.Module):
    """u = K x + b: Gaussian in, Gaussian out (exact moments)."""

    def __init__(self, gain: list[list[float]], bias: list[float]) -> None:
        super().__init__()
        self.gain = torch.nn.Parameter(torch.tensor(gain, dtype=F64))
        self.bias = torch.nn.Parameter(torch.tensor(bias, dtype=F64))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x @ self.gain.T + self.bias

    def gaussian_moments(
        self, mean: torch.Tensor, cov: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        return self.gain @ mean + self.bias, self.gain @ cov @ self.gain.T, self.gain.T


def toy_model() -> SimpleNamespace:
    """A fitted full-state SE GP model of x' = x + 0.1 [x1, −sin(x0) − 0.3 x1 + u], no angles."""
    g = torch.Generator().manual_seed(0)
    x = torch.rand(80, 2, generator=g, dtype=F64) * 3 - 1.5
    u = torch.rand(80, 1, generator=g, dtype=F64) * 2 - 1
    delta = 0.1 * torch.stack([x[:, 1], -torch.sin(x[:, 0]) - 0.3 * x[:, 1] + u[:, 0]], dim=1)
    delta = delta + 0.03 * torch.randn(80, 2, generator=g, dtype=F64)  # Γ well conditioned
    gp = ExactGP(SquaredExponential(KernelShape(2, 3), lengthscale=1.0), noise_std=0.05)
    gp.set_data(torch.cat([x, u], dim=1), delta)
    MarginalLikelihoodFit(max_iterations=100)(gp)
    gp.precompute()
    return SimpleNamespace(features=AngleFeatures(2, []), gp=gp)


def monte_carlo(
    model: SimpleNamespace, policy: LinearPolicy, mean: torch.Tensor, cov: torch.Tensor, steps: int
) -> list[torch.Tensor]:
    """Particles of x_t under the same semantics: an independent GP draw per step."""
    g = torch.Generator().manual_seed(1)
    x = mean + torch.randn(200_000, 2, generator=g, dtype=F64) @ torch.linalg.cholesky(cov).T
    out = [x]
    with torch.no_grad():
        for _ in range(steps):
            f_mean, f_var = model.gp.predict(torch.cat([x, policy(x)], dim=1))
            x = x + (f_mean + f_var.sqrt() * torch.randn(f_mean.shape, generator=g, dtype=F64)).T
            out.append(x)
    return out


def test_moment_matching_equals_monte_carlo_after_one_and_several_steps() -> None:
    """One step from a Gaussian with a linear policy: the moments are exact (MC agrees to
    its sampling error); after 8 steps the Gaussian approximation is close (stated below)."""
    model, policy = toy_model(), LinearPolicy([[-0.8, -0.5]], [0.1])
    mean = torch.tensor([0.6, -0.2], dtype=F64)
    cov = torch.tensor([[0.05, 0.01], [0.01, 0.08]], dtype=F64)
    cost = SaturatingQuadratic(angles=[], projection=[[1.0, 0.0]], offset=[0.0], width=1.0)
    with torch.no_grad():
        predicted = MomentMatchingRollout(model, policy, cost, mean, cov, horizon=8)()
    particles = monte_carlo(model, policy, mean, cov, 8)
    one = particles[1]
    std = one.std(0)
    assert torch.allclose(predicted.means[1], one.mean(0), atol=float(4 * std.max() / 450))
    assert torch.allclose(predicted.covariances[1], torch.cov(one.T), rtol=0.015, atol=1e-4)
    last = particles[8]
    assert torch.allclose(predicted.means[8], last.mean(0), atol=0.02 * float(last.std(0).max()))
    assert torch.allclose(predicted.covariances[8], torch.cov(last.T), rtol=0.05, atol=2e-4)


def test_expected_cost_gradient_matches_finite_differences() -> None:
    model, policy = toy_model(), LinearPolicy([[-0.8, -0.5]], [0.1])
    mean = torch.tensor([0.6, -0.2], dtype=F64)
    cov = torch.tensor([[0.05, 0.01], [0.01, 0.08]], dtype=F64)
    cost = SaturatingQuadratic(angles=[], projection=[[1.0, 0.0]], offset=[0.0], width=0.5)
    predict = MomentMatchingRollout(model, policy, cost, mean, cov, horizon=6)
    predict().total_cost.backward()
    analytic = policy.gain.grad.clone()
    step = 1e-6
    for j in range(2):
        with torch.no_grad():
            policy.gain[0, j] += step
            up = float(predict().total_cost)
            policy.gain[0, j] -= 2 * step
            down = float(predict().total_cost)
            policy.gain[0, j] += step
        assert float(analytic[0, j]) == pytest.approx((up - down) / (2 * step), rel=1e-5)


def compose_train(*overrides: str):  # noqa: ANN201
    with initialize_config_dir(version_base="1.3", config_dir=str(CONFIG_DIR)):
        return compose("train", overrides=list(overrides))


@pytest.mark.parametrize(
    "overrides,key",
    [
        (["kernel=sp"], "kernel"),
        (["kernel=se_p2"], "kernel"),
        (["model=speed_integration"], "model"),
        (["policy.squash=tanh"], "policy.squash"),
        ([], "cost"),  # the default (2.16) cost has no closed-form Gaussian expectation
    ],
)
def test_pilco_refuses_what_it_cannot_match(overrides: list[str], key: str) -> None:
    extra = [] if key == "cost" else ["cost=cartpole_pilco"]
    cfg = compose_train("algorithm=pilco", *extra, *overrides)
    with pytest.raises(ConfigError, match=f"needs {key}|{key}="):
        build(cfg)


def test_pilco_builds_and_its_expected_cost_is_that_of_a_point_mass() -> None:
    c = build(compose_train("algorithm=pilco", "cost=cartpole_pilco")).components
    assert c.policy.squash == "sine" and c.policy.num_basis == 100
    x0 = torch.as_tensor(c.system.initial_mean, dtype=F64)
    tiny = torch.eye(4, dtype=F64) * 1e-14
    assert float(c.cost.expected_gaussian(x0, tiny)) == pytest.approx(float(c.cost(x0)), abs=1e-9)


@pytest.mark.parametrize(
    "override",
    [
        "+optimizer.schedule.dropout=0.25",
        "+optimizer.max_steps=100",
        "+optimizer.horizon_stages=[1.0]",
    ],
)
def test_blackdrops_refuses_gradient_only_options(override: str) -> None:
    key = override.split("=")[0].lstrip("+").split(".")[1]
    with pytest.raises(ConfigError, match=f"optimizer.{key} is an option of gradient-based"):
        build(compose_train("algorithm=blackdrops", override))


def test_pilco_initial_policy_sits_where_the_system_starts() -> None:
    """PILCO's scenario initialisation: centres from N(x̄0, 0.1² I) mapped to x*, small
    pre-saturation outputs near x0 (≈ 0.1 N(0, 1) in units of the sine's argument)."""
    from mcpilco.optim.rollout import ParticleRollout

    c = build(compose_train("algorithm=pilco", "cost=cartpole_pilco")).components
    rollout = ParticleRollout.for_system(c.system, c.model, c.policy, c.cost, c.estimator)
    c.optimizer.initialise_policy(rollout, torch.Generator().manual_seed(0))
    centres = c.policy.centres.detach()  # [n_b, 5] = [p, ṗ, θ̇, sin θ, cos θ]
    assert float(centres[:, [0, 1, 2, 3]].abs().max()) < 0.5
    assert float(centres[:, 4].min()) > 0.9  # cos θ ≈ 1: hanging
    x0 = c.model.encode(torch.zeros(1, 4, dtype=F64))
    with torch.no_grad():
        u = c.policy(x0)
    assert 0 < float(u.abs()) < 0.5 * c.policy.u_max
