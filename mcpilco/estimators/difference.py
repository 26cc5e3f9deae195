"""Velocities by finite differences of measured positions, optionally low-passed."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mcpilco.errors import ConfigError
from mcpilco.estimators.positions import PositionBasedEstimator
from mcpilco.systems.base import MechanicalSystem


def _signal():  # type: ignore[no-untyped-def]
    """scipy.signal, imported on first use (it adds seconds to every process start)."""
    from scipy import signal

    return signal


def _butterworth(order: int, cutoff_hz: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Digital low-pass Butterworth ``(b, a)`` with a[0] = 1 (scipy's design)."""
    b, a = _signal().butter(order, cutoff_hz, btype="low", fs=1.0 / dt)
    return np.asarray(b, dtype=np.float64), np.asarray(a, dtype=np.float64)


class CausalDifference(PositionBasedEstimator):
    """Causal velocity estimate: ``v_t = (q_t − q_{t−1}) / dt`` (``v_0 = 0``: the system
    starts at rest), optionally through a causal Butterworth low-pass of ``order`` at
    ``cutoff_hz``; positions are the readings. Offline and online parts are the same
    filter (offline with :func:`scipy.signal.lfilter`, online step by step in torch,
    batched and differentiable), so closed-loop estimates equal the offline ones.

    Args:
        system: the plant. cutoff_hz: low-pass cut-off in Hz (None: no filter).
        order: low-pass order (1 = first-order low-pass).
    """

    name = "difference"

    def __init__(
        self, system: MechanicalSystem, cutoff_hz: float | None = None, order: int = 1
    ) -> None:
        super().__init__(system, self.name)
        if not isinstance(order, int) or order < 1:
            raise ConfigError(f"estimator.order must be a positive integer, got {order!r}")
        self.cutoff_hz = None if cutoff_hz is None else self.nyquist_check("cutoff_hz", cutoff_hz)
        self.order = order
        if self.cutoff_hz is None:
            self.b, self.a = np.array([1.0]), np.array([1.0])
        else:
            self.b, self.a = _butterworth(order, self.cutoff_hz, self.dt)
        # the online filter's taps as Python floats (traced as constants when compiled)
        self.taps = (tuple(map(float, self.b)), tuple(map(float, self.a)))

    # --------------------------------------------------------------------- offline
    def causal_velocities(self, positions: np.ndarray) -> np.ndarray:
        """Low-passed backward differences ``[T+1, d_q]`` of positions ``[T+1, d_q]``."""
        raw = np.diff(positions, axis=0, prepend=positions[:1]) / self.dt
        return _signal().lfilter(self.b, self.a, raw, axis=0)

    def offline(
        self, measurements: np.ndarray, dt: float, actions: np.ndarray | None = None
    ) -> np.ndarray:
        positions = self.positions_of(measurements)
        return self.assemble(positions, self.causal_velocities(positions))

    # ---------------------------------------------------------------------- online
    def online_reset(self, batch_size: int, like: torch.Tensor) -> dict[str, Any]:
        """No previous reading yet; filter states zero ``[B, d_q]`` each."""
        zeros = torch.zeros(batch_size, self.num_positions, dtype=like.dtype, device=like.device)
        return {"previous": None, "filter": [zeros] * (len(self.a) - 1)}

    def online_step(
        self, measurement: torch.Tensor, memory: dict[str, Any]
    ) -> tuple[torch.Tensor, dict[str, Any]]:
        positions = self.positions_of_tensor(measurement)
        previous = positions if memory["previous"] is None else memory["previous"]
        raw = (positions - previous) / self.dt
        velocities, filter_state = self._filter_step(raw, memory["filter"])
        estimate = self.assemble_tensor(positions, velocities)
        return estimate, {"previous": positions, "filter": filter_state}

    def _filter_step(
        self, value: torch.Tensor, state: list[torch.Tensor]
    ) -> tuple[torch.Tensor, list[torch.Tensor]]:
        """One sample of the IIR filter, transposed direct form II (scipy's lfilter)."""
        b, a = self.taps
        if not state:
            return b[0] * value, state
        output = b[0] * value + state[0]
        new_state = []
        for i in range(1, len(a)):
            following = state[i] if i < len(state) else 0.0
            new_state.append(b[i] * value - a[i] * output + following)
        return output, new_state


class ZeroPhaseDifference(CausalDifference):
    """Offline: zero-phase (forward-backward, :func:`scipy.signal.filtfilt`) Butterworth
    low-pass of ``offline_order`` on the positions, then central differences — accurate,
    not causal, for GP training data (MC-PILCO4PMS, thesis §3.1). Online: the causal
    estimator of :class:`CausalDifference` with ``order`` (first-order by default) at the
    same cut-off. With ``cutoff_hz=None`` neither part filters: central differences of the
    readings offline, causal differences online (the thesis's Furuta pendulum, §3.4.1).

    Args:
        system: the plant. cutoff_hz: cut-off of both filters (Hz), or None for no filter.
        order: online low-pass order. offline_order: offline low-pass order.
    """

    name = "zero_phase"

    def __init__(
        self,
        system: MechanicalSystem,
        cutoff_hz: float | None,
        order: int = 1,
        offline_order: int = 2,
    ) -> None:
        super().__init__(system, cutoff_hz, order)
        if not isinstance(offline_order, int) or offline_order < 1:
            raise ConfigError(
                f"estimator.offline_order must be a positive integer, got {offline_order!r}"
            )
        self.offline_order = offline_order
        self.offline_taps = (
            None if self.cutoff_hz is None else _butterworth(offline_order, self.cutoff_hz, self.dt)
        )

    def offline(
        self, measurements: np.ndarray, dt: float, actions: np.ndarray | None = None
    ) -> np.ndarray:
        positions = self.positions_of(measurements)
        if self.offline_taps is None:
            return self.assemble(positions, np.gradient(positions, self.dt, axis=0))
        offline_b, offline_a = self.offline_taps
        padding = min(3 * max(len(offline_a), len(offline_b)), len(positions) - 1)
        smooth = _signal().filtfilt(offline_b, offline_a, positions, axis=0, padlen=padding)
        return self.assemble(smooth, np.gradient(smooth, self.dt, axis=0))
