"""Joint reference trajectories r(t) with their derivatives ṙ(t), r̈(t): the thesis's
growing sines, explicit sums of sines, and the random excitation of data collection."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass, field

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


class Reference(ABC):
    """One joint reference: positions r(t), velocities ṙ(t), accelerations r̈(t) of n
    joints (rad, rad/s, rad/s²) for t in [0, ``duration``] s.

    Attributes:
        label: names the reference in a run (``summary.csv``'s ``reference`` column and
            ``tracking/<label>.npz``): letters, digits, ``_``, ``-``, ``.``.
        duration: s.
    """

    label: str
    duration: float

    @property
    @abstractmethod
    def num_joints(self) -> int:
        """n."""

    @abstractmethod
    def __call__(self, time: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(r, ṙ, r̈), each ``[..., n]`` at ``time`` (s)."""

    def parameters(self) -> dict[str, np.ndarray]:
        """The arrays that define the reference (stored beside its tracking run)."""
        return {}


@dataclass(frozen=True)
class SineReference(Reference):
    """r_j(t) = o_j + A t sin(2π F_j t) per joint (thesis §5.4.2, o_j = 0 there).

    Attributes:
        amplitude: A in rad/s. frequencies: F_j in Hz ``[n]``. offsets: o_j in rad ``[n]``
        (None: zeros). duration: s. label: see :class:`Reference`.
    """

    amplitude: float
    frequencies: np.ndarray
    offsets: np.ndarray | None = None
    duration: float = 5.0
    label: str = "sine"

    @classmethod
    def random(
        cls,
        rng: np.random.Generator,
        num_joints: int,
        amplitude: float = 0.165,
        frequency_mean: float | np.ndarray = 0.5,
        frequency_std: float = 1.0,
        **kwargs: object,
    ) -> SineReference:
        """F_j ~ N(frequency_mean, frequency_std²), drawn from ``rng``."""
        draws = frequency_mean + frequency_std * rng.standard_normal(num_joints)
        return cls(amplitude, draws, **kwargs)  # type: ignore[arg-type]

    @property
    def num_joints(self) -> int:
        return len(self.frequencies)

    def __call__(self, time: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = np.asarray(time, dtype=np.float64)[..., None]
        w = 2 * np.pi * np.asarray(self.frequencies, dtype=np.float64)
        sine, cosine = np.sin(w * t), np.cos(w * t)
        offsets = 0.0 if self.offsets is None else np.asarray(self.offsets, dtype=np.float64)
        position = offsets + self.amplitude * t * sine
        velocity = self.amplitude * (sine + t * w * cosine)
        acceleration = self.amplitude * (2 * w * cosine - t * w**2 * sine)
        return position, velocity, acceleration

    def parameters(self) -> dict[str, np.ndarray]:
        offsets = np.zeros(self.num_joints) if self.offsets is None else self.offsets
        return {
            "amplitude": np.asarray(self.amplitude),
            "frequencies": np.asarray(self.frequencies),
            "offsets": np.asarray(offsets, dtype=np.float64),
        }


@dataclass(frozen=True)
class SumOfSinesReference(Reference):
    """r_j(t) = o_j + Σ_k A_jk sin(2π f_jk t + φ_jk), any number of terms K_j per joint.

    Attributes:
        amplitudes: per joint, the A_jk in rad (``n`` arrays ``[K_j]``).
        frequencies: per joint, the f_jk in Hz (same shapes).
        phases: per joint, the φ_jk in rad (same shapes).
        offsets: o_j in rad ``[n]``.
        duration: s. label: see :class:`Reference`.
    """

    amplitudes: tuple[np.ndarray, ...]
    frequencies: tuple[np.ndarray, ...]
    phases: tuple[np.ndarray, ...]
    offsets: np.ndarray
    duration: float = 5.0
    label: str = "sines"
    _terms: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] = field(
        init=False, repr=False, compare=False
    )

    def __post_init__(self) -> None:
        # All terms flattened, with the joint of each: one vectorised evaluation.
        joint = np.concatenate([np.full(len(a), j) for j, a in enumerate(self.amplitudes)])
        flat = [
            np.concatenate(values) for values in (self.amplitudes, self.frequencies, self.phases)
        ]
        object.__setattr__(self, "_terms", (joint.astype(int), *flat))

    @property
    def num_joints(self) -> int:
        return len(self.amplitudes)

    def __call__(self, time: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = np.asarray(time, dtype=np.float64)[..., None]
        joint, amplitude, frequency, phase = self._terms
        w = 2 * np.pi * frequency
        angle = w * t + phase  # [..., terms]
        sine, cosine = np.sin(angle), np.cos(angle)
        select = np.zeros((len(joint), self.num_joints))
        select[np.arange(len(joint)), joint] = 1.0  # terms → joints
        position = self.offsets + (amplitude * sine) @ select
        velocity = (amplitude * w * cosine) @ select
        acceleration = -(amplitude * w**2 * sine) @ select
        return position, velocity, acceleration

    def parameters(self) -> dict[str, np.ndarray]:
        joint, amplitude, frequency, phase = self._terms
        return {
            "term_joint": joint,
            "amplitudes": amplitude,
            "frequencies": frequency,
            "phases": phase,
            "offsets": self.offsets,
        }
