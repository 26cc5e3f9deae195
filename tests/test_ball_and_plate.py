"""Ball-and-plate simulator against rolling-ball physics, its data cut and p(x0)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mcpilco.models.features import AngleFeatures
from mcpilco.models.speed_integration import SpeedIntegration
from mcpilco.optim.rollout import ParticleRollout
from mcpilco.policies import TriangularWaveExploration
from mcpilco.systems import BallAndPlate

G = 9.81


def hold(action: np.ndarray):  # type: ignore[no-untyped-def]
    return lambda measurement, step: action


def test_ball_at_rest_on_a_level_plate_stays_at_rest() -> None:
    system = BallAndPlate()
    state = np.array([0.03, -0.05, 0, 0, 0, 0, 0, 0], dtype=float)
    for _ in range(30):
        state = system.step(state, np.zeros(2))
    np.testing.assert_allclose(state, [0.03, -0.05, 0, 0, 0, 0, 0, 0], atol=1e-12)


@pytest.mark.parametrize("tilt", [0.02, -0.05, 0.1])
def test_tilted_plate_accelerates_a_rolling_ball_by_five_sevenths_g_sin(tilt: float) -> None:
    system = BallAndPlate()
    state = np.array([0, 0, 0, 0, tilt, 0, 0, 0], dtype=float)  # still plate, ball at rest
    after = system.step(state, np.zeros(2))
    acceleration = after[2] / system.dt
    np.testing.assert_allclose(acceleration, -5 / 7 * G * np.sin(tilt), rtol=1e-9)
    np.testing.assert_allclose(after[0], 0.5 * acceleration * system.dt**2, rtol=1e-9)
    assert after[1] == 0 and after[3] == 0


def test_motors_turn_by_the_commanded_increment_within_a_step() -> None:
    system = BallAndPlate()
    state = np.zeros(8)
    for u in ([0.05, -0.02], [-0.01, 0.03]):
        after = system.step(state, np.array(u))
        np.testing.assert_allclose(after[4:6], state[4:6] + u, atol=1e-12)
        np.testing.assert_allclose(after[6:8], np.array(u) / system.dt, atol=1e-12)
        state = after


def test_rollout_is_cut_when_the_ball_reaches_the_border() -> None:
    system = BallAndPlate()
    rng = np.random.default_rng(0)
    x0 = np.array([0.05, 0, 0, 0, -0.2, 0, 0, 0], dtype=float)  # tilted: rolls to +x
    trajectory = system.rollout(hold(np.zeros(2)), x0, system.num_steps, rng)
    limit = system.plate_half_width - system.ball_radius
    assert trajectory.states.shape[0] < system.num_steps + 1
    assert np.all(trajectory.states[:-1, 0] <= limit) and trajectory.states[-1, 0] > limit
    assert trajectory.actions.shape[0] == trajectory.states.shape[0] - 1
    assert trajectory.measurements.shape[0] == trajectory.states.shape[0]
    metrics = system.evaluate(trajectory)
    assert metrics["collided"] and not metrics["success"]
    centred = system.rollout(hold(np.zeros(2)), np.zeros(8), system.num_steps, rng)
    assert centred.states.shape[0] == system.num_steps + 1
    assert system.evaluate(centred)["success"]  # a ball at rest in the centre


def test_uniform_initial_states_on_the_system_and_on_the_particles() -> None:
    system = BallAndPlate()
    rng = np.random.default_rng(1)
    draws = np.array([system.sample_initial_state(rng) for _ in range(4000)])
    half = system.initial_std
    assert np.all(np.abs(draws) <= half + 1e-15)
    np.testing.assert_allclose(draws[:, 0].var(), half[0] ** 2 / 3, rtol=0.1)  # U(−a, a)
    rollout = ParticleRollout(
        model=None,  # type: ignore[arg-type]  # only the initial draw is used below
        policy=None,  # type: ignore[arg-type]
        cost=None,  # type: ignore[arg-type]
        estimator=None,  # type: ignore[arg-type]
        initial_mean=torch.zeros(8, dtype=torch.float64),
        initial_std=torch.as_tensor(half),
        horizon=1,
        initial_uniform=True,
    )
    start = torch.randn(20000, 8, generator=torch.Generator().manual_seed(0), dtype=torch.float64)
    particles = rollout.initial_states(start)
    assert torch.all(particles.abs() <= rollout.initial_std)
    histogram = torch.histc(particles[:, 0], bins=10, min=-half[0], max=half[0])
    np.testing.assert_allclose(histogram.numpy() / 20000, 0.1, atol=0.01)  # flat


def test_velocity_changes_are_linear_in_the_physical_basis() -> None:
    """Over one 30 Hz step the simulator's velocity changes are fitted by a linear
    combination of the SP basis to within 1 % of their spread."""
    system = BallAndPlate()
    features = AngleFeatures(8, system.angle_indices)
    rng = np.random.default_rng(2)
    states, actions, changes = [], [], []
    for _ in range(400):
        x = rng.uniform(-1, 1, 8) * [0.08, 0.08, 0.2, 0.2, 0.1, 0.1, 1.0, 1.0]
        u = rng.uniform(-1, 1, 2) * system.u_max
        states.append(x)
        actions.append(u)
        changes.append(system.step(x, u)[[2, 3, 6, 7]] - x[[2, 3, 6, 7]])
    x = torch.as_tensor(np.array(states))
    basis = system.velocity_basis(features.encode(x), torch.as_tensor(np.array(actions)))
    targets = np.array(changes)
    for k in range(4):
        design = basis[k].numpy()
        weights, *_ = np.linalg.lstsq(design, targets[:, k], rcond=None)
        residual = targets[:, k] - design @ weights
        assert residual.std() < 0.01 * targets[:, k].std(), k


def test_triangular_exploration_is_bounded_and_periodic() -> None:
    explore = TriangularWaveExploration(
        u_max=0.07, action_dim=2, rng=np.random.default_rng(3), dt=0.05, noise_std=0.0
    )
    signal = np.array([explore(np.zeros(4), t) for t in range(200)])
    assert np.all(np.abs(signal) <= 0.035 + 1e-12)  # amplitude u_max / 2
    period_steps = explore.periods / 0.05
    for k in range(2):
        assert signal[:, k].max() > 0.03 and signal[:, k].min() < -0.03
        step = int(round(period_steps[k]))
        if abs(period_steps[k] - step) < 1e-9:
            np.testing.assert_allclose(signal[step:, k], signal[:-step, k], atol=1e-12)


def test_integrated_triangular_exploration_moves_the_reference_along_the_triangle() -> None:
    """integrated=True: the running sum of the actions (the motor angle) is the triangle
    itself, starting level; each action (an angle change) stays within ±u_max."""
    dt, amplitude = 1 / 30, 0.02
    explore = TriangularWaveExploration(
        u_max=np.radians(4.0),
        action_dim=2,
        rng=np.random.default_rng(5),
        dt=dt,
        amplitude=amplitude,
        noise_std=0.0,
        integrated=True,
    )
    actions = np.array([explore(np.zeros(8), t) for t in range(90)])
    angles = np.cumsum(actions, axis=0)  # after steps 1 … 90
    times = dt * np.arange(1, 91)[:, None]
    cycle = np.remainder(times / explore.periods + 0.25, 1.0)
    expected = amplitude * (4 * np.abs(cycle - 0.5) - 1)  # 0 at t = 0, rising first
    np.testing.assert_allclose(angles, expected, atol=1e-12)
    assert np.all(np.abs(actions) <= np.radians(4.0) + 1e-12)
    assert angles.max() > 0.9 * amplitude and angles.min() < -0.9 * amplitude
    explore(np.zeros(8), 0)  # a new rollout starts level again
    assert np.allclose(explore.applied, explore.wave(1))


def test_known_coordinates_move_the_motors_as_the_simulator_does() -> None:
    """Speed-integration with known coordinates: two GP outputs (the ball), the motors'
    next angle and speed exactly the simulator's, the ball integrated at constant
    acceleration from the GP's velocity change."""
    system = BallAndPlate()
    model = SpeedIntegration(
        system,
        kernel=None,
        gp=None,
        fit=None,
        known_coordinates=True,  # type: ignore[arg-type]
    )
    assert model.output_names == ["d_x2", "d_x3"] and model.num_outputs == 2
    rng = np.random.default_rng(4)
    x = rng.uniform(-1, 1, (5, 8)) * [0.08, 0.08, 0.2, 0.2, 0.1, 0.1, 1.0, 1.0]
    u = rng.uniform(-1, 1, (5, 2)) * system.u_max
    deltas = rng.normal(size=(2, 5)) * 0.01  # GP velocity changes of bx, by
    following = model.transition(torch.as_tensor(x), torch.as_tensor(u), torch.as_tensor(deltas))
    following = following.numpy()
    for m in range(5):
        simulated = system.step(x[m], u[m])
        np.testing.assert_allclose(following[m, 4:8], simulated[4:8], atol=1e-12)
    dt = system.dt
    np.testing.assert_allclose(following[:, 2:4], x[:, 2:4] + deltas.T, atol=1e-15)
    np.testing.assert_allclose(
        following[:, 0:2], x[:, 0:2] + dt * x[:, 2:4] + 0.5 * dt * deltas.T, atol=1e-15
    )
    states = torch.as_tensor(np.array([system.step(x[0], u[0]), x[0]]))
    np.testing.assert_allclose(
        model.gp_targets(states).numpy(), (x[0] - states[0].numpy())[[2, 3]][None]
    )
    basis = model.output_basis(torch.zeros(3, model.gp_input_dim, dtype=torch.float64))
    assert basis.shape[0] == 2  # the ball's rows only


def test_known_coordinates_need_a_system_that_knows_some() -> None:
    from mcpilco.errors import ConfigError
    from mcpilco.systems import CartPole

    with pytest.raises(ConfigError, match="known_coordinates"):
        SpeedIntegration(
            CartPole(),
            kernel=None,
            gp=None,
            fit=None,
            known_coordinates=True,  # type: ignore[arg-type]
        )
