"""Shared layout of estimators that reconstruct velocities from measured positions."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch

from mcpilco.errors import ConfigError
from mcpilco.estimators.base import StateEstimator
from mcpilco.systems.base import MechanicalSystem


class PositionBasedEstimator(StateEstimator):
    """An estimator for a partially measurable system: the sensors read the d_q positions
    (any order, nothing else); estimates are full states ``[..., d_x]`` in state order.

    Args:
        system: the plant (indices, dt, sensors). name: the estimator's config name, for
            messages.
    """

    def __init__(self, system: MechanicalSystem, name: str) -> None:
        measured = list(system.sensors.measured)
        positions = list(system.position_indices)
        if sorted(measured) != sorted(positions):
            raise ConfigError(
                f"estimator={name} estimates velocities from measured positions: "
                f"system.measured_indices must be the positions {positions}, got {measured}"
            )
        self.system = system
        self.dt = system.dt
        # reading column of each position (in position_indices order)
        self.position_columns = [measured.index(i) for i in positions]
        layout = positions + list(system.velocity_indices)  # column k of [q, q̇] is state layout[k]
        self.state_order = [layout.index(i) for i in range(system.state_dim)]

    @property
    def num_positions(self) -> int:
        return len(self.position_columns)

    def nyquist_check(self, name: str, cutoff_hz: float) -> float:
        """``cutoff_hz`` if it is positive and below the Nyquist frequency 1/(2 dt)."""
        nyquist = 0.5 / self.dt
        if not 0 < cutoff_hz < nyquist:
            raise ConfigError(
                f"estimator.{name}={cutoff_hz} must be in (0, {nyquist:g}) Hz, the Nyquist "
                f"frequency of system.dt={self.dt:g}"
            )
        return float(cutoff_hz)

    def per_position(self, key: str, value: float | Sequence[float]) -> np.ndarray:
        """``estimator.<key>`` as ``[d_q]`` positive floats from one value or one per
        position."""
        array = np.asarray(value, dtype=np.float64).reshape(-1)
        if array.size not in (1, self.num_positions) or np.any(~(array > 0)):
            raise ConfigError(
                f"estimator.{key} needs one positive value or {self.num_positions}, got {value!r}"
            )
        return np.broadcast_to(array, (self.num_positions,)).copy()

    def positions_of(self, readings: np.ndarray) -> np.ndarray:
        """Positions ``[..., d_q]`` (position_indices order) from readings ``[..., d_y]``."""
        return readings[..., self.position_columns]

    def positions_of_tensor(self, readings: torch.Tensor) -> torch.Tensor:
        return readings[..., self.position_columns]

    def assemble(self, positions: np.ndarray, velocities: np.ndarray) -> np.ndarray:
        """States ``[..., d_x]`` from positions and velocities ``[..., d_q]`` each."""
        return np.concatenate([positions, velocities], axis=-1)[..., self.state_order]

    def assemble_tensor(self, positions: torch.Tensor, velocities: torch.Tensor) -> torch.Tensor:
        return torch.cat([positions, velocities], dim=-1)[..., self.state_order]


def rts_backward(
    filtered: np.ndarray,
    filtered_cov: np.ndarray,
    predicted: np.ndarray,
    predicted_cov: np.ndarray,
    transitions: np.ndarray,
) -> np.ndarray:
    """Rauch–Tung–Striebel backward pass over a Kalman filter's output.

    Args:
        filtered, predicted: posterior and prior means ``[T, d_q, n]`` (prior at step t
            given readings up to t − 1). filtered_cov, predicted_cov: ``[T, d_q, n, n]``.
        transitions: ``[T−1, n, n]``, step t → t+1.

    Returns:
        Smoothed means ``[T, d_q, n]``.
    """
    smoothed = filtered.copy()
    for t in range(len(filtered) - 2, -1, -1):
        back_gain = filtered_cov[t] @ transitions[t].T @ np.linalg.inv(predicted_cov[t + 1])
        correction = smoothed[t + 1] - predicted[t + 1]
        smoothed[t] = filtered[t] + np.einsum("qij,qj->qi", back_gain, correction)
    return smoothed
