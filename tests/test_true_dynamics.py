"""The true-dynamics model: torch equations of motion against the numpy ODE and scipy."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mcpilco.errors import ConfigError
from mcpilco.gp import ExactGP, MarginalLikelihoodFit
from mcpilco.kernels import SquaredExponential
from mcpilco.models import TrueDynamics
from mcpilco.systems import BallAndPlate, CartPole, FurutaPendulum
from mcpilco.systems.base import OdeSystem


def random_states(system: OdeSystem, count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    states = rng.normal(0.0, 2.0, (count, system.state_dim))
    actions = rng.uniform(-system.u_max, system.u_max, (count, system.action_dim))
    return states, actions


def make_model(system: OdeSystem, substeps: int = 4) -> TrueDynamics:
    def kernel(shape: object) -> SquaredExponential:  # never used: no GP is built
        raise AssertionError("the true-dynamics model must not build a kernel")

    return TrueDynamics(
        system, kernel, ExactGP, MarginalLikelihoodFit(max_iterations=1), substeps=substeps
    )


@pytest.mark.parametrize("system", [FurutaPendulum(), CartPole()], ids=["furuta", "cartpole"])
def test_torch_derivatives_equal_the_numpy_ode(system: OdeSystem) -> None:
    states, actions = random_states(system, 50, 0)
    batched = system.torch_derivatives(torch.as_tensor(states), torch.as_tensor(actions))
    expected = np.stack([system.derivatives(x, u) for x, u in zip(states, actions, strict=True)])
    np.testing.assert_allclose(batched.numpy(), expected, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("system", [FurutaPendulum(), CartPole()], ids=["furuta", "cartpole"])
def test_step_matches_the_adaptive_integration_of_the_system(system: OdeSystem) -> None:
    """RK4 with 4 substeps per sample against DOP853 at 1e-10 (the system's own step)."""
    states, actions = random_states(system, 20, 1)
    states[:, 1::2] *= 0.5  # moderate velocities
    model = make_model(system)
    predicted = model.step(torch.as_tensor(states), torch.as_tensor(actions), torch.zeros(2, 20))
    expected = np.stack([system.step(x, u) for x, u in zip(states, actions, strict=True)])
    np.testing.assert_allclose(predicted.numpy(), expected, atol=1e-5)


def test_step_gradient_matches_finite_differences() -> None:
    system = FurutaPendulum()
    model = make_model(system)
    states = torch.tensor([[0.3, -2.0, 2.5, 4.0]], dtype=torch.float64)
    actions = torch.tensor([[3.0]], dtype=torch.float64, requires_grad=True)
    noise = torch.zeros(2, 1, dtype=torch.float64)
    model.step(states, actions, noise)[0, 3].backward()
    assert actions.grad is not None
    step = 1e-6
    plus = model.step(states, actions.detach() + step, noise)[0, 3]
    minus = model.step(states, actions.detach() - step, noise)[0, 3]
    assert float(actions.grad) == pytest.approx(float((plus - minus) / (2 * step)), rel=1e-6)


def test_fit_learns_nothing_and_checkpoints_are_empty() -> None:
    model = make_model(FurutaPendulum())
    report = model.fit([np.zeros((91, 4))], [np.zeros((90, 1))])
    assert report.num_samples == 90 and report.seconds == 0.0
    assert model.checkpoint() == {} and model.hyperparameters() == {}
    model.load_gp({})


def test_a_system_without_torch_equations_is_refused() -> None:
    with pytest.raises(ConfigError, match="torch equations of motion"):
        make_model(BallAndPlate())
    with pytest.raises(ConfigError, match="substeps"):
        make_model(FurutaPendulum(), substeps=0)
