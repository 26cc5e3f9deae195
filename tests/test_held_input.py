"""The held-input smoother and central differences against independent references: closed-form
zero-order-hold motion, the bias formula of central differences, a brute-force Gaussian
posterior of the same linear model, quadrature of the process noise; accuracy on the
simulated Furuta pendulum; bad input."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad_vec
from scipy.linalg import expm

from mcpilco.errors import ConfigError
from mcpilco.estimators import CausalDifference, HeldInputSmoother, ZeroPhaseDifference
from mcpilco.policies.exploration import UniformRandomExploration
from mcpilco.systems import CartPole, FurutaPendulum

DT = 1.0 / 30.0
# cart-pole layout used only for its two measured positions and one input
LAYOUT = {"dt": DT, "measured_indices": [0, 2], "measurement_noise_std": 1e-7}


def held_input_motion(
    gains: np.ndarray, drift: np.ndarray, inputs: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Exact positions and velocities ``[T+1, d_q]`` of q̈ = drift + gains·u with u held
    over each interval of DT, from rest at 0."""
    steps = len(inputs)
    positions = np.zeros((steps + 1, len(gains)))
    velocities = np.zeros_like(positions)
    for t, u in enumerate(inputs):
        acceleration = drift + gains * u
        positions[t + 1] = positions[t] + velocities[t] * DT + 0.5 * acceleration * DT**2
        velocities[t + 1] = velocities[t] + acceleration * DT
    return positions, velocities


@pytest.fixture(scope="module")
def bang_bang() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Inputs ±1 switching at random over 3 s; gains 50 and −30 (units/s² per input),
    drift 0 and 5 units/s²: (inputs [90, 1], positions, velocities [91, 2])."""
    rng = np.random.default_rng(0)
    inputs = rng.choice([-1.0, 1.0], size=(90, 1))
    positions, velocities = held_input_motion(
        np.array([50.0, -30.0]), np.array([0.0, 5.0]), inputs[:, 0]
    )
    return inputs, positions, velocities


def test_central_differences_offline_causal_online_without_cutoff(bang_bang) -> None:  # type: ignore[no-untyped-def]
    inputs, positions, _ = bang_bang
    system = CartPole(**LAYOUT)
    central = ZeroPhaseDifference(system, cutoff_hz=None)
    estimate = central.offline(positions, DT)
    by_hand = (positions[2:] - positions[:-2]) / (2 * DT)
    np.testing.assert_allclose(estimate[1:-1, [1, 3]], by_hand, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(estimate[:, [0, 2]], positions)
    # online it is the plain causal difference
    assert central.taps == CausalDifference(system).taps


def test_central_differences_err_by_a_quarter_step_of_the_acceleration_jump(bang_bang) -> None:  # type: ignore[no-untyped-def]
    """With held inputs (q+ − q−)/2h = q̇ + h (a_after − a_before)/4 exactly."""
    inputs, positions, velocities = bang_bang
    estimate = ZeroPhaseDifference(CartPole(**LAYOUT), cutoff_hz=None).offline(positions, DT)
    jump = np.outer(np.diff(inputs[:, 0]), [50.0, -30.0])  # [T-1, 2]
    np.testing.assert_allclose(estimate[1:-1, [1, 3]] - velocities[1:-1], DT * jump / 4, atol=1e-9)


def test_held_input_smoother_recovers_velocities_of_held_input_motion(bang_bang) -> None:  # type: ignore[no-untyped-def]
    inputs, positions, velocities = bang_bang
    system = CartPole(**LAYOUT)
    smoothed = HeldInputSmoother(system).offline(positions, DT, inputs)[:, [1, 3]]
    central = ZeroPhaseDifference(system, cutoff_hz=None).offline(positions, DT)[:, [1, 3]]
    central_rms = np.sqrt(np.mean((central - velocities) ** 2))
    smoothed_rms = np.sqrt(np.mean((smoothed - velocities) ** 2))
    assert central_rms > 0.3  # h·|Δa|/4 with |Δa| up to 100 units/s²
    assert smoothed_rms < 0.01 * central_rms


def test_discretisation_matches_the_closed_form_and_quadrature() -> None:
    estimator = HeldInputSmoother(CartPole(**LAYOUT), jerk_psd=[2e4, 3e5], gain_psd=[7e2, 5e3])
    u = 0.7
    transition, noise = estimator.discretise(np.array([[u]]))
    drift = np.zeros((4, 4))
    drift[0, 1] = drift[1, 2] = 1.0
    drift[1, 3] = u
    # drift³ = 0, so the exponential is a quadratic polynomial
    np.testing.assert_allclose(
        transition[0], np.eye(4) + drift * DT + drift @ drift * DT**2 / 2, atol=1e-13
    )
    for position, (jerk, gain) in enumerate([(2e4, 7e2), (3e5, 5e3)]):
        intensity = np.diag([0.0, 0.0, jerk, gain])
        integral, _ = quad_vec(
            lambda s, q=intensity: expm(drift * s) @ q @ expm(drift * s).T, 0.0, DT, epsabs=1e-14
        )
        np.testing.assert_allclose(noise[0, position], integral, rtol=1e-8, atol=1e-12 * jerk)


def test_smoother_equals_the_gaussian_posterior_of_its_model() -> None:
    """The RTS pass against brute-force conditioning of the joint Gaussian of all hidden
    states and readings of the same linear model (5 readings, 1 position)."""
    system = CartPole(dt=DT, measured_indices=[0, 2], measurement_noise_std=[2e-3, 1e-3])
    estimator = HeldInputSmoother(system, jerk_psd=3e4, gain_psd=2e2)
    rng = np.random.default_rng(1)
    inputs = rng.uniform(-1, 1, size=(4, 1))
    readings = rng.normal(size=(5, 2)) * 0.01
    smoothed = estimator.smooth(readings, inputs)  # [5, 2, 4]
    transition, noise = estimator.discretise(inputs)
    for position in range(2):
        size, steps = 4, 5
        mean = np.zeros(size * steps)
        cov = np.zeros((size * steps, size * steps))
        mean[0] = readings[0, position]
        cov[:size, :size] = estimator.initial_covariance[position]
        for t in range(1, steps):
            a = transition[t - 1]
            rows, previous = slice(size * t, size * (t + 1)), slice(size * (t - 1), size * t)
            mean[rows] = a @ mean[previous]
            # Cov(x_t, x_s) for s < t follows from Cov(x_{t-1}, x_s)
            cov[rows, : size * t] = a @ cov[previous, : size * t]
            cov[: size * t, rows] = cov[rows, : size * t].T
            cov[rows, rows] = a @ cov[previous, previous] @ a.T + noise[t - 1, position]
        observe = np.zeros((steps, size * steps))
        observe[np.arange(steps), np.arange(steps) * size] = 1.0
        gram = observe @ cov @ observe.T + np.eye(steps) * estimator.reading_variance[position]
        posterior = mean + cov @ observe.T @ np.linalg.solve(
            gram, readings[:, position] - observe @ mean
        )
        np.testing.assert_allclose(
            smoothed[:, position], posterior.reshape(steps, size), rtol=1e-7, atol=1e-9
        )


def test_held_input_smoother_beats_central_differences_on_the_furuta_pendulum() -> None:
    """Encoders of 4096 counts, ±10 V switching at random: the smoother's velocity error is
    a fraction of central differences'."""
    system = FurutaPendulum(measured_indices=[0, 2], quantization=2 * np.pi / 4096)
    rng = np.random.default_rng(4)
    explore = UniformRandomExploration(u_max=10.0, action_dim=1, rng=rng)
    trajectory = system.rollout(explore, np.zeros(4), system.num_steps, rng)
    truth = trajectory.states[:, [1, 3]]

    def rms(estimator) -> float:  # type: ignore[no-untyped-def]
        estimate = estimator.offline(trajectory.measurements, system.dt, trajectory.actions)
        return float(np.sqrt(np.mean((estimate[:, [1, 3]] - truth) ** 2)))

    central, smoothed = rms(ZeroPhaseDifference(system, None)), rms(HeldInputSmoother(system))
    assert smoothed < 0.3 * central


def test_held_input_smoother_refuses_bad_input() -> None:
    system = CartPole(**LAYOUT)
    for key, value in (("jerk_psd", -1.0), ("gain_psd", [1.0, 2.0, 3.0])):
        with pytest.raises(ConfigError, match=f"estimator.{key}"):
            HeldInputSmoother(system, **{key: value})  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="estimator.initial_gain_std"):
        HeldInputSmoother(system, initial_gain_std=0.0)
    with pytest.raises(ConfigError, match="measured_indices"):
        HeldInputSmoother(CartPole())
    with pytest.raises(ValueError, match="needs the actions"):
        HeldInputSmoother(system).offline(np.zeros((5, 2)), DT)
