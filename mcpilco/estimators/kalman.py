"""Kalman filter (online) and Rauch–Tung–Striebel smoother (offline) with a
constant-acceleration model per measured position."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import torch

from mcpilco.errors import ConfigError
from mcpilco.estimators.positions import PositionBasedEstimator, rts_backward
from mcpilco.systems.base import MechanicalSystem


class KalmanEstimator(PositionBasedEstimator):
    """Each position q follows a constant-acceleration model with white jerk: hidden
    state ``s = [q, q̇, q̈]``, ``s_{t+1} = A s_t + w_t``, reading ``y_t = q_t + e_t`` with
    Var(e) = the sensors' σ² + r²/12. ``Q = j² Γ`` with Γ the integrated-white-jerk matrix
    for sampling time dt and j² = ``jerk_psd`` (units²/s⁵).

    The filter starts from ``s_0 = [y_0, 0, 0]`` (at rest) with covariance
    diag(Var(e), ``initial_velocity_std``², ``initial_acceleration_std``²). The covariances
    and gains do not depend on the data, so the gains are computed once (numpy) and the
    online step is three batched torch operations, differentiable in the readings.

    Args:
        system: the plant. jerk_psd: j², one per position or one for all.
        initial_velocity_std, initial_acceleration_std: prior spread at t = 0.
    """

    name = "kalman"

    def __init__(
        self,
        system: MechanicalSystem,
        jerk_psd: float | Sequence[float] = 1e4,
        initial_velocity_std: float = 0.1,
        initial_acceleration_std: float = 1.0,
    ) -> None:
        super().__init__(system, self.name)
        psd = self.per_position("jerk_psd", jerk_psd)
        for key, value in (
            ("initial_velocity_std", initial_velocity_std),
            ("initial_acceleration_std", initial_acceleration_std),
        ):
            if not value > 0:
                raise ConfigError(f"estimator.{key} must be > 0, got {value!r}")
        dt = self.dt
        self.transition = np.array([[1.0, dt, dt**2 / 2], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
        gamma = np.array(
            [
                [dt**5 / 20, dt**4 / 8, dt**3 / 6],
                [dt**4 / 8, dt**3 / 3, dt**2 / 2],
                [dt**3 / 6, dt**2 / 2, dt],
            ]
        )
        self.process_noise = psd[:, None, None] * gamma  # [d_q, 3, 3]
        variance = system.sensors.variance()[self.position_columns]  # [d_q]
        self.reading_variance = variance
        prior = np.zeros((self.num_positions, 3, 3))
        prior[:, 0, 0] = variance
        prior[:, 1, 1] = initial_velocity_std**2
        prior[:, 2, 2] = initial_acceleration_std**2
        self.initial_covariance = prior
        self.gains = self._gain_table()
        self._tensor_cache: dict[tuple[torch.dtype, torch.device], Any] = {}

    # --------------------------------------------------------------- covariance pass
    def _predict_update(self, covariance: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One step of the covariance recursion: (prior P⁻, gain K, posterior P)."""
        a = self.transition
        predicted = a @ covariance @ a.T + self.process_noise  # [d_q, 3, 3]
        innovation = predicted[:, 0, 0] + self.reading_variance  # [d_q]
        gain = predicted[:, :, 0] / innovation[:, None]  # [d_q, 3]
        updated = predicted - gain[:, :, None] * predicted[:, None, 0, :]
        return predicted, gain, updated

    def _gain_table(self, max_steps: int = 100_000, tolerance: float = 1e-14) -> np.ndarray:
        """Gains ``[K, d_q, 3]`` for steps 1..K, K the first step whose gain equals the
        previous one to ``tolerance`` (relative): from there on the filter is stationary
        and every later step uses the last gain."""
        covariance = self.initial_covariance.copy()
        gains: list[np.ndarray] = []
        for _ in range(max_steps):
            _, gain, covariance = self._predict_update(covariance)
            if gains and np.max(np.abs(gain - gains[-1])) <= tolerance * np.max(np.abs(gain)):
                break
            gains.append(gain)
        return np.stack(gains)

    def _tensors(
        self, dtype: torch.dtype, device: torch.device
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Aᵀ ``[3, 3]`` and the gain table ``[K, d_q, 3]`` as tensors, converted once per
        dtype and device."""
        key = (dtype, device)
        if key not in self._tensor_cache:
            self._tensor_cache[key] = (
                torch.as_tensor(self.transition.T, dtype=dtype, device=device),
                torch.as_tensor(self.gains, dtype=dtype, device=device),
            )
        return self._tensor_cache[key]

    # --------------------------------------------------------------------- offline
    def smooth(self, positions: np.ndarray) -> np.ndarray:
        """RTS-smoothed hidden states ``[T+1, d_q, 3]`` from positions ``[T+1, d_q]``."""
        steps = positions.shape[0]
        a = self.transition
        filtered = np.zeros((steps, self.num_positions, 3))
        filtered_cov = np.zeros((steps, self.num_positions, 3, 3))
        predicted = np.zeros_like(filtered)
        predicted_cov = np.zeros_like(filtered_cov)
        filtered[0, :, 0] = positions[0]
        filtered_cov[0] = self.initial_covariance
        for t in range(1, steps):
            predicted_cov[t], gain, filtered_cov[t] = self._predict_update(filtered_cov[t - 1])
            predicted[t] = filtered[t - 1] @ a.T
            filtered[t] = predicted[t] + gain * (positions[t] - predicted[t, :, 0])[:, None]
        transitions = np.broadcast_to(a, (max(steps - 1, 0), 3, 3))
        return rts_backward(filtered, filtered_cov, predicted, predicted_cov, transitions)

    def offline(
        self, measurements: np.ndarray, dt: float, actions: np.ndarray | None = None
    ) -> np.ndarray:
        smoothed = self.smooth(self.positions_of(measurements))
        return self.assemble(smoothed[..., 0], smoothed[..., 1])

    # ---------------------------------------------------------------------- online
    def online_reset(self, batch_size: int, like: torch.Tensor) -> dict[str, Any]:
        """The gains travel in the memory as a tensor, so a compiled rollout step reads
        them as data instead of guarding on Python state that changes every step."""
        transition_t, gains = self._tensors(like.dtype, like.device)
        return {"state": None, "step": 0, "transition_t": transition_t, "gains": gains}

    def online_step(
        self, measurement: torch.Tensor, memory: dict[str, Any]
    ) -> tuple[torch.Tensor, dict[str, Any]]:
        positions = self.positions_of_tensor(measurement)  # [B, d_q]
        step = memory["step"]
        if memory["state"] is None:
            zeros = torch.zeros_like(positions)
            state = torch.stack([positions, zeros, zeros], dim=-1)  # [B, d_q, 3]
        else:
            gains = memory["gains"]
            gain = gains[min(step, gains.shape[0]) - 1]
            prior = torch.matmul(memory["state"], memory["transition_t"])
            state = torch.addcmul(prior, (positions - prior[..., 0]).unsqueeze(-1), gain)
        estimate = self.assemble_tensor(state[..., 0], state[..., 1])
        return estimate, {**memory, "state": state, "step": step + 1}
