"""Offline smoother for inputs held between samples (zero-order hold); causal differences online."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mcpilco.errors import ConfigError
from mcpilco.estimators.difference import CausalDifference
from mcpilco.estimators.positions import rts_backward
from mcpilco.systems.base import MechanicalSystem


def _expm(matrices: np.ndarray) -> np.ndarray:
    """Matrix exponentials of ``[..., n, n]`` (scipy, imported on first use)."""
    from scipy.linalg import expm

    return np.asarray(expm(matrices))


class HeldInputSmoother(CausalDifference):
    """Offline: a Rauch–Tung–Striebel smoother that knows the inputs are held constant
    between readings. Online: causal differences (optionally low-passed), as
    :class:`CausalDifference`.

    Central or smoothed differences assume a smooth acceleration, but a mechanical system
    driven through a zero-order hold has an acceleration that jumps at every sample where
    the input changes. With inputs of ±10 V switching at 30 Hz that bias reaches tenths of
    a rad/s, and GPs trained on such velocities learn the wrong dynamics. This smoother
    models each measured position q as

        q̈(t) = f(t) + Σ_k g_k(t) u_k(t),

    with u the recorded, piecewise-constant inputs, f a drift driven by white jerk
    (``jerk_psd``, units²/s⁵) and the gains g_k random walks (``gain_psd``,
    (units/s²/input)²/s). Hidden state ``[q, q̇, f, g_1 … g_du]`` per position; each sample
    interval is discretised exactly for its held input (Van Loan); readings have the
    sensors' variance. No model of the system is needed: f and g are estimated from the
    readings themselves.

    Args:
        system: the plant. jerk_psd, gain_psd: process-noise intensities, one value or one
            per position. initial_velocity_std, initial_acceleration_std, initial_gain_std:
            prior spread of q̇, f and g at the first reading (the system starts near rest).
        cutoff_hz, order: the online low-pass of :class:`CausalDifference` (None: none).
    """

    name = "held_input"

    def __init__(
        self,
        system: MechanicalSystem,
        jerk_psd: float | Sequence[float] = 1e5,
        gain_psd: float | Sequence[float] = 1e3,
        initial_velocity_std: float = 0.1,
        initial_acceleration_std: float = 10.0,
        initial_gain_std: float = 100.0,
        cutoff_hz: float | None = None,
        order: int = 1,
    ) -> None:
        super().__init__(system, cutoff_hz, order)
        jerk = self.per_position("jerk_psd", jerk_psd)
        gain = self.per_position("gain_psd", gain_psd)
        for key, value in (
            ("initial_velocity_std", initial_velocity_std),
            ("initial_acceleration_std", initial_acceleration_std),
            ("initial_gain_std", initial_gain_std),
        ):
            if not (isinstance(value, (int, float)) and value > 0):
                raise ConfigError(f"estimator.{key} must be > 0, got {value!r}")
        self.num_inputs = system.action_dim
        size = 3 + self.num_inputs
        # reading variance per position; a floor keeps noise-free sensors well posed
        variance = system.sensors.variance()[self.position_columns]
        self.reading_variance = np.maximum(variance, 1e-12)
        prior = np.zeros((self.num_positions, size, size))
        prior[:, 0, 0] = self.reading_variance
        prior[:, 1, 1] = initial_velocity_std**2
        prior[:, 2, 2] = initial_acceleration_std**2
        for k in range(self.num_inputs):
            prior[:, 3 + k, 3 + k] = initial_gain_std**2
        self.initial_covariance = prior
        # white-noise intensities [d_q, n, n] of ḟ and ġ_k
        intensity = np.zeros((self.num_positions, size, size))
        intensity[:, 2, 2] = jerk
        for k in range(self.num_inputs):
            intensity[:, 3 + k, 3 + k] = gain
        self.intensity = intensity

    def discretise(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Exact transitions ``A [T, n, n]`` and process noises ``Q [T, d_q, n, n]`` of the
        T sample intervals with held inputs ``actions [T, d_u]`` (Van Loan's method)."""
        steps, size = actions.shape[0], 3 + self.num_inputs
        drift = np.zeros((steps, size, size))
        drift[:, 0, 1] = 1.0
        drift[:, 1, 2] = 1.0
        drift[:, 1, 3:] = actions
        block = np.zeros((steps, self.num_positions, 2 * size, 2 * size))
        block[..., :size, :size] = -drift[:, None]
        block[..., :size, size:] = self.intensity[None]
        block[..., size:, size:] = np.swapaxes(drift, -1, -2)[:, None]
        exponential = _expm(block * self.dt)
        transition = np.swapaxes(exponential[:, 0, size:, size:], -1, -2)  # [T, n, n]
        noise = transition[:, None] @ exponential[..., :size, size:]  # [T, d_q, n, n]
        return transition, 0.5 * (noise + np.swapaxes(noise, -1, -2))

    def smooth(self, positions: np.ndarray, actions: np.ndarray) -> np.ndarray:
        """Smoothed hidden states ``[T+1, d_q, n]`` from positions ``[T+1, d_q]`` and the
        held inputs ``[T, d_u]``."""
        steps, size = positions.shape[0], 3 + self.num_inputs
        transition, noise = self.discretise(actions)
        filtered = np.zeros((steps, self.num_positions, size))
        filtered_cov = np.zeros((steps, self.num_positions, size, size))
        predicted = np.zeros_like(filtered)
        predicted_cov = np.zeros_like(filtered_cov)
        predicted[0, :, 0] = positions[0]
        predicted_cov[0] = self.initial_covariance
        for t in range(steps):
            if t > 0:
                a = transition[t - 1]
                predicted[t] = filtered[t - 1] @ a.T
                predicted_cov[t] = a @ filtered_cov[t - 1] @ a.T + noise[t - 1]
            innovation = predicted_cov[t, :, 0, 0] + self.reading_variance  # [d_q]
            gain = predicted_cov[t, :, :, 0] / innovation[:, None]  # [d_q, n]
            residual = positions[t] - predicted[t, :, 0]
            filtered[t] = predicted[t] + gain * residual[:, None]
            filtered_cov[t] = predicted_cov[t] - gain[:, :, None] * predicted_cov[t, :, None, 0, :]
        return rts_backward(filtered, filtered_cov, predicted, predicted_cov, transition)

    def offline(
        self, measurements: np.ndarray, dt: float, actions: np.ndarray | None = None
    ) -> np.ndarray:
        if actions is None:
            raise ValueError(f"estimator={self.name} needs the actions held between readings")
        positions = self.positions_of(measurements)
        actions = np.asarray(actions, dtype=np.float64).reshape(len(positions) - 1, -1)
        smoothed = self.smooth(positions, actions)
        return self.assemble(smoothed[..., 0], smoothed[..., 1])
