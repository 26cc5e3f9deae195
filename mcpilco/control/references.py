"""Joint reference trajectories: random excitation for data, sinusoids for tracking."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mcpilco.errors import ConfigError


def filtered_noise(
    rng: np.random.Generator,
    num_samples: int,
    num_joints: int,
    dt: float,
    cutoff_hz: float,
    std: float | Sequence[float],
    order: int = 2,
) -> np.ndarray:
    """Gaussian white noise through an ``order``-th order Butterworth low-pass at
    ``cutoff_hz`` (causal), scaled to ``std`` rad per joint: ``[num_samples, n]`` (thesis
    §5.4.1's data-collection reference)."""
    from scipy import signal

    if not 0 < cutoff_hz < 0.5 / dt:
        raise ConfigError(f"data.cutoff_hz={cutoff_hz} must be in (0, {0.5 / dt}) Hz")
    sos = signal.butter(order, cutoff_hz, fs=1.0 / dt, output="sos")
    warm_up = int(5.0 / (cutoff_hz * dt))  # let the filter forget its zero state
    noise = rng.standard_normal((num_samples + warm_up, num_joints))
    filtered = signal.sosfilt(sos, noise, axis=0)[warm_up:]
    scale = np.broadcast_to(np.asarray(std, dtype=np.float64), (num_joints,))
    return filtered / filtered.std(axis=0) * scale


@dataclass(frozen=True)
class SineReference:
    """r_j(t) = A t sin(2π F_j t) per joint (thesis §5.4.2), with its derivatives.

    Attributes:
        amplitude: A in rad/s. frequencies: F_j in Hz ``[n]``.
    """

    amplitude: float
    frequencies: np.ndarray

    @classmethod
    def random(
        cls,
        rng: np.random.Generator,
        num_joints: int,
        amplitude: float = 0.165,
        frequency_mean: float = 0.5,
        frequency_std: float = 1.0,
    ) -> SineReference:
        """F_j ~ N(frequency_mean, frequency_std²), drawn from ``rng``."""
        return cls(amplitude, frequency_mean + frequency_std * rng.standard_normal(num_joints))

    def __call__(self, time: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(r, ṙ, r̈), each ``[..., n]`` at ``time`` (s)."""
        t = np.asarray(time, dtype=np.float64)[..., None]
        w = 2 * np.pi * self.frequencies
        sine, cosine = np.sin(w * t), np.cos(w * t)
        position = self.amplitude * t * sine
        velocity = self.amplitude * (sine + t * w * cosine)
        acceleration = self.amplitude * (2 * w * cosine - t * w**2 * sine)
        return position, velocity, acceleration
