"""Sensors and state estimators against independent references (scipy, a textbook Kalman
filter written out here), accuracy on a simulated noisy cart-pole, gradients, bad input."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy import signal

from mcpilco.errors import ConfigError
from mcpilco.estimators import (
    CausalDifference,
    FullStateMeasurement,
    KalmanEstimator,
    ZeroPhaseDifference,
)
from mcpilco.policies.exploration import UniformRandomExploration
from mcpilco.systems import CartPole

PMS = {"dt": 1.0 / 30.0, "measured_indices": [0, 2], "measurement_noise_std": 3e-3}


@pytest.fixture(scope="module")
def recorded() -> tuple[CartPole, np.ndarray, np.ndarray]:
    """A 6 s cart-pole trajectory at 30 Hz under random actions: (system, true states
    [T+1, 4], position readings [T+1, 2])."""
    system = CartPole(trial_duration=6.0, **PMS)
    rng = np.random.default_rng(3)
    explore = UniformRandomExploration(u_max=10.0, action_dim=1, rng=rng)
    trajectory = system.rollout(explore, np.zeros(4), system.num_steps, rng)
    return system, trajectory.states, trajectory.measurements


def run_online(estimator, readings: np.ndarray, batch: int = 3) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Feed readings ``[T+1, d_y]`` step by step to ``batch`` identical streams; return
    the first stream's estimates ``[T+1, d_x]`` (checking the streams agree)."""
    memory = estimator.online_reset(batch, torch.zeros((), dtype=torch.float64))
    estimates = []
    for reading in torch.as_tensor(readings):
        estimate, memory = estimator.online_step(reading.expand(batch, -1), memory)
        estimates.append(estimate)
    stacked = torch.stack(estimates)  # [T+1, B, d_x]
    torch.testing.assert_close(stacked, stacked[:, :1].expand_as(stacked))
    return stacked[:, 0].numpy()


def test_sensors_read_positions_noisily_and_quantised() -> None:
    system = CartPole(measured_indices=[2, 0], measurement_noise_std=1e-9, quantization=0.01)
    reading = system.measure(np.array([0.123456, 1.0, -0.98765, 2.0]), np.random.default_rng(0))
    np.testing.assert_allclose(reading, [-0.99, 0.12], atol=1e-12)
    readings = np.array(
        [system.sensors.read(np.zeros(4), np.random.default_rng(k)) for k in range(3)]
    )
    assert readings.shape == (3, 2)


def test_simulated_readings_have_the_configured_noise() -> None:
    system = CartPole(measured_indices=[0, 2], measurement_noise_std=[0.1, 0.2], quantization=0.5)
    generator = torch.Generator().manual_seed(0)
    states = torch.zeros(200_000, 4, dtype=torch.float64)
    gaussian = torch.randn(200_000, 2, generator=generator, dtype=torch.float64)
    uniform = torch.rand(200_000, 2, generator=generator, dtype=torch.float64)
    readings = system.sensors.simulate(states, gaussian, uniform)
    expected = np.sqrt(np.array([0.1, 0.2]) ** 2 + 0.5**2 / 12.0)  # Gaussian + U(-r/2, r/2)
    np.testing.assert_allclose(readings.std(0).numpy(), expected, rtol=0.01)


@pytest.mark.parametrize("cutoff,order", [(None, 1), (7.5, 1), (5.0, 2)])
def test_causal_difference_online_equals_scipy_lfilter(recorded, cutoff, order) -> None:  # type: ignore[no-untyped-def]
    system, _, readings = recorded
    estimator = CausalDifference(system, cutoff_hz=cutoff, order=order)
    online = run_online(estimator, readings)
    # reference: backward differences (0 at t = 0), then scipy's causal Butterworth filter
    raw = np.vstack([np.zeros((1, 2)), np.diff(readings, axis=0) / system.dt])
    if cutoff is not None:
        b, a = signal.butter(order, cutoff, fs=1.0 / system.dt)
        raw = signal.lfilter(b, a, raw, axis=0)
    np.testing.assert_allclose(online[:, [0, 2]], readings, atol=1e-12)
    np.testing.assert_allclose(online[:, [1, 3]], raw, atol=1e-9)
    np.testing.assert_allclose(estimator.offline(readings, system.dt), online, atol=1e-9)


def textbook_kalman(readings: np.ndarray, dt: float, psd: float, r: float, p0: np.ndarray):  # type: ignore[no-untyped-def]
    """One scalar position, constant-acceleration model: x̂_t for every t (plain loop)."""
    a = np.array([[1, dt, dt * dt / 2], [0, 1, dt], [0, 0, 1]])
    q = psd * np.array(
        [
            [dt**5 / 20, dt**4 / 8, dt**3 / 6],
            [dt**4 / 8, dt**3 / 3, dt**2 / 2],
            [dt**3 / 6, dt**2 / 2, dt],
        ]
    )
    h = np.array([[1.0, 0.0, 0.0]])
    x, p = np.array([readings[0], 0.0, 0.0]), p0.copy()
    out = [x]
    for y in readings[1:]:
        x, p = a @ x, a @ p @ a.T + q
        s = h @ p @ h.T + r
        k = p @ h.T / s
        x = x + (k * (y - h @ x)).ravel()
        p = (np.eye(3) - k @ h) @ p
        out.append(x)
    return np.array(out)


def test_kalman_online_equals_textbook_filter(recorded) -> None:  # type: ignore[no-untyped-def]
    system, _, readings = recorded
    estimator = KalmanEstimator(system, jerk_psd=[2e3, 5e4])
    online = run_online(estimator, readings)
    for column, (position, velocity, psd) in enumerate([(0, 1, 2e3), (2, 3, 5e4)]):
        p0 = np.diag([3e-3**2, 0.1**2, 1.0**2])
        reference = textbook_kalman(readings[:, column], system.dt, psd, 3e-3**2, p0)
        np.testing.assert_allclose(online[:, position], reference[:, 0], atol=1e-10)
        np.testing.assert_allclose(online[:, velocity], reference[:, 1], atol=1e-8)


def test_kalman_gains_reach_their_stationary_value_and_keep_it() -> None:
    """Far past the point where the precomputed gain table ends, the online filter still
    equals the textbook recursion."""
    system = CartPole(dt=1 / 30, measured_indices=[0, 2], measurement_noise_std=3e-3)
    estimator = KalmanEstimator(system, jerk_psd=1e4)
    steps = 3 * len(estimator.gains)
    readings = np.random.default_rng(5).normal(0.0, 0.1, size=(steps, 2))
    online = run_online(estimator, readings)
    p0 = np.diag([3e-3**2, 0.1**2, 1.0**2])
    reference = textbook_kalman(readings[:, 1], system.dt, 1e4, 3e-3**2, p0)
    np.testing.assert_allclose(online[:, 3], reference[:, 1], rtol=1e-9, atol=1e-9)


def velocity_rms(estimates: np.ndarray, states: np.ndarray) -> float:
    return float(np.sqrt(np.mean((estimates[:, [1, 3]] - states[:, [1, 3]]) ** 2)))


def test_offline_estimates_beat_causal_ones(recorded) -> None:  # type: ignore[no-untyped-def]
    system, states, readings = recorded
    kalman = KalmanEstimator(system, jerk_psd=[2e3, 5e4])
    causal_kalman = velocity_rms(run_online(kalman, readings), states)
    smoothed = velocity_rms(kalman.offline(readings, system.dt), states)
    assert smoothed < 0.7 * causal_kalman
    zero_phase = ZeroPhaseDifference(system, cutoff_hz=7.5)
    causal_lowpass = velocity_rms(run_online(zero_phase, readings), states)
    offline = velocity_rms(zero_phase.offline(readings, system.dt), states)
    assert offline < 0.7 * causal_lowpass
    raw = velocity_rms(run_online(CausalDifference(system), readings), states)
    assert offline < raw and smoothed < raw


def test_gradients_flow_through_online_estimators(recorded) -> None:  # type: ignore[no-untyped-def]
    system, _, readings = recorded
    window = torch.as_tensor(readings[:6]).clone().requires_grad_()
    for estimator in (
        CausalDifference(system, cutoff_hz=7.5, order=2),
        KalmanEstimator(system),
    ):

        def last_estimate(x: torch.Tensor, estimator=estimator) -> torch.Tensor:  # type: ignore[no-untyped-def]
            memory = estimator.online_reset(1, x)
            for reading in x:
                estimate, memory = estimator.online_step(reading[None], memory)
            return estimate

        assert torch.autograd.gradcheck(last_estimate, (window,))


def test_inconsistent_estimator_configs_fail_with_the_key() -> None:
    pms = CartPole(**PMS)
    with pytest.raises(ConfigError, match="cutoff_hz=20"):
        CausalDifference(pms, cutoff_hz=20.0)  # Nyquist at 30 Hz is 15 Hz
    with pytest.raises(ConfigError, match="measured_indices"):
        KalmanEstimator(CartPole(**{**PMS, "measured_indices": [0]}))
    with pytest.raises(ConfigError, match="measured_indices"):
        CausalDifference(CartPole())  # velocities are measured: nothing to estimate
    from mcpilco.models import SpeedIntegration

    model = SpeedIntegration(pms, kernel=None, gp=None, fit=None)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="estimator=none"):
        model.check_estimator(FullStateMeasurement(pms))
    with pytest.raises(ConfigError, match="measured_indices"):
        CartPole(measured_indices=[0, 7])
    with pytest.raises(ConfigError, match="quantization"):
        CartPole(measured_indices=[0, 2], quantization=[0.1, 0.1, 0.1])


@pytest.mark.parametrize(
    "overrides",
    [
        ["estimator=zero_phase", "system.measured_indices=[0,2]", "estimator.cutoff_hz=5.0"],
        ["estimator=kalman", "system.measured_indices=[0,2]", "estimator.jerk_psd=1e3"],
        # DF: histories of noisy readings; its GP (noise variance ~2e-6) evaluates Ĵ with
        # ~1e-10 round-off: a difference over h = 1e-4 errs by 0.8-1.5 % (measured on two
        # product orders), over h = 3e-3 by 1e-4-6e-4 — hence that step, and a looser
        # tolerance
        ["+experiment=cartpole_df", "system.dt=0.05"],
    ],
    ids=["zero_phase", "kalman", "derivative_free"],
)
def test_policy_gradient_through_simulated_sensors_matches_finite_differences(
    overrides: list[str],
) -> None:
    """MC-PILCO4PMS / DF rollouts (the policy reads simulated noisy readings through the
    online estimator or as a history): autograd's directional derivative of Ĵ equals a
    central finite difference, and the readings' noise changes Ĵ."""
    from hydra import compose, initialize_config_dir

    from mcpilco.build import build
    from mcpilco.optim.policy_optimizer import frozen
    from mcpilco.optim.rollout import ParticleRollout
    from tests.test_config import CONFIG_DIR

    step, tolerance = (3e-3, 1e-2) if "+experiment=cartpole_df" in overrides else (1e-6, 1e-5)
    overrides = [*overrides, "system.trial_duration=0.4"]
    with initialize_config_dir(version_base="1.3", config_dir=str(CONFIG_DIR)):
        experiment = build(compose("train", overrides=overrides))
    c = experiment.components
    rng = np.random.default_rng(0)
    trajectory = c.system.rollout(c.exploration(rng=rng), np.zeros(4), 20, rng)
    c.model.fit([c.estimator.offline(trajectory.measurements, c.system.dt)], [trajectory.actions])
    rollout = ParticleRollout.for_system(c.system, c.model, c.policy, c.cost, c.estimator)

    def cost() -> torch.Tensor:
        return rollout(5, 0.0, torch.Generator().manual_seed(1)).total_cost

    direction = torch.randn(c.policy.weights.shape, generator=torch.Generator().manual_seed(2))
    with frozen(c.model):
        cost().backward()
        analytic = float((c.policy.weights.grad * direction).sum())
        with torch.no_grad():
            c.policy.weights.add_(step * direction)
            plus = float(cost())
            c.policy.weights.sub_(2 * step * direction)
            minus = float(cost())
    assert abs(analytic) > 1e-6
    assert analytic == pytest.approx((plus - minus) / (2 * step), rel=tolerance)
    assert rollout._reading_noise(5, torch.Generator(), {"dtype": torch.float64}) is not None
