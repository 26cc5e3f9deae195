"""Model structures: integration rule, targets, features, fit/predict plumbing."""

from __future__ import annotations

import numpy as np
import torch

from mcpilco.gp import ExactGP, MarginalLikelihoodFit
from mcpilco.kernels import SquaredExponential
from mcpilco.models import AngleFeatures, FullState, SpeedIntegration
from mcpilco.systems import CartPole


def make(structure: type, kernel=SquaredExponential):  # type: ignore[no-untyped-def]
    return structure(
        system=CartPole(),
        kernel=kernel,
        gp=ExactGP,
        fit=MarginalLikelihoodFit(max_iterations=30),
    )


def test_speed_integration_is_exact_for_constant_acceleration() -> None:
    model = make(SpeedIntegration)
    dt, acceleration = 0.05, torch.tensor([1.7, -3.2], dtype=torch.float64)
    state = torch.tensor([[0.3, -0.4, 0.1, 2.0]], dtype=torch.float64)  # [p, ṗ, θ, θ̇]
    q0, v0 = state[0, [0, 2]], state[0, [1, 3]]
    for step in range(1, 41):
        deltas = (acceleration * dt).unsqueeze(-1)  # [G=2, M=1]
        state = model.transition(state, torch.zeros(1, 1, dtype=torch.float64), deltas)
        t = step * dt
        torch.testing.assert_close(state[0, [0, 2]], q0 + v0 * t + 0.5 * acceleration * t**2)
        torch.testing.assert_close(state[0, [1, 3]], v0 + acceleration * t)


def test_full_state_adds_the_predicted_change() -> None:
    model = make(FullState)
    state = torch.randn(5, 4, dtype=torch.float64)
    deltas = torch.randn(4, 5, dtype=torch.float64)
    torch.testing.assert_close(model.transition(state, state[:, :1], deltas), state + deltas.T)


def test_targets_are_one_step_differences() -> None:
    states = torch.randn(11, 4, dtype=torch.float64)
    si = make(SpeedIntegration).gp_targets(states)
    fs = make(FullState).gp_targets(states)
    torch.testing.assert_close(si, states[1:, [1, 3]] - states[:-1, [1, 3]])
    torch.testing.assert_close(fs, states[1:] - states[:-1])


def test_angle_features_encode_and_decode() -> None:
    features = AngleFeatures(4, [2]).to(torch.float64)
    x = torch.tensor([[0.5, -1.0, 2.5, 3.0]], dtype=torch.float64)
    encoded = features.encode(x)
    expected = torch.tensor([[0.5, -1.0, 3.0, np.sin(2.5), np.cos(2.5)]], dtype=torch.float64)
    torch.testing.assert_close(encoded, expected)
    torch.testing.assert_close(features.decode(encoded), x)


def test_fit_then_step_learns_a_linear_system(generator: torch.Generator) -> None:
    """On data from q̈ = −q the model's one-step prediction beats a 1e-3 error."""
    model = make(SpeedIntegration).to(torch.float64)
    dt = model.system.dt
    rng = np.random.default_rng(0)
    states, actions = [], []
    for _ in range(3):
        x = np.zeros((31, 4))
        x[0] = rng.normal(size=4)
        u = rng.uniform(-1, 1, size=(30, 1))
        for t in range(30):  # exact for ZOH acceleration a = −p + u, −θ
            a = np.array([-x[t, 0] + u[t, 0], -x[t, 2]])
            x[t + 1, [1, 3]] = x[t, [1, 3]] + dt * a
            x[t + 1, [0, 2]] = x[t, [0, 2]] + dt * x[t, [1, 3]] + 0.5 * dt**2 * a
        states.append(x)
        actions.append(u)
    report = model.fit(states, actions)
    assert report.num_samples == 90 and report.num_kept == 90
    probe = torch.as_tensor(states[0][5:6])
    action = torch.as_tensor(actions[0][5:6])
    predicted = model.step(probe, action, torch.zeros(2, 1, dtype=torch.float64))
    assert float((predicted - torch.as_tensor(states[0][6:7])).abs().max()) < 1e-3


def test_relative_reduction_leaves_every_dropped_sample_predicted_within_its_limit() -> None:
    """Reference-code SoD (``reduction_mode=relative``, β = 0.5): every sample the fit drops
    is predicted by the kept ones with latent std ≤ β σ_n of each output (adding samples only
    lowers a posterior variance), and a pendulum swinging through the same states keeps few."""
    model = SpeedIntegration(
        system=CartPole(),
        kernel=SquaredExponential,
        gp=ExactGP,
        fit=MarginalLikelihoodFit(max_iterations=30),
        reduction_threshold=0.5,
        reduction_mode="relative",
    )
    dt, rng = model.system.dt, np.random.default_rng(1)
    states, actions = [], []
    for _ in range(3):  # the same small-amplitude motion three times over: redundant data
        x = np.zeros((41, 4))
        x[0] = [0.1, 0.0, 0.2, 0.0] + 1e-3 * rng.normal(size=4)
        u = np.zeros((40, 1))
        for t in range(40):
            a = np.array([-x[t, 0], -np.sin(x[t, 2])])
            x[t + 1, [1, 3]] = x[t, [1, 3]] + dt * a
            x[t + 1, [0, 2]] = x[t, [0, 2]] + dt * x[t, [1, 3]] + 0.5 * dt**2 * a
        states.append(x)
        actions.append(u)
    report = model.fit(states, actions)
    assert report.num_samples == 120 and report.num_kept < 60, report
    inputs, _ = model.dataset(states, actions)
    gp = model.gp
    assert gp is not None
    kept = (inputs[:, None, :] == gp.train_inputs[None, :, :]).all(-1).any(-1)  # [N]
    with torch.no_grad():
        _, variance = gp.predict(inputs[~kept])  # [G, N_dropped] latent, from the kept samples
        limit = (0.5 * gp.noise_variance.sqrt())[:, None] ** 2
    assert int(kept.sum()) == report.num_kept
    assert bool((variance <= limit * (1 + 1e-9)).all())


def test_angle_feature_gradient(generator: torch.Generator) -> None:
    features = AngleFeatures(4, [2]).to(torch.float64)
    x = torch.randn(6, 4, generator=generator, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(features.encode, (x,))


def test_policy_angle_columns_of_the_cartpole_state() -> None:
    """[p, ṗ, θ̇, sin θ, cos θ]: the pair is (3, 4), written out by hand."""
    assert make(SpeedIntegration).policy_angle_columns == [(3, 4)]
    assert make(FullState).policy_angle_columns == [(3, 4)]
