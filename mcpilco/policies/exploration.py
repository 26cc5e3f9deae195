"""Exploration controllers for the first rollout."""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from mcpilco.errors import ConfigError
from mcpilco.extension import ExtensionPoint


def _signal():  # type: ignore[no-untyped-def]
    """scipy.signal, imported on first use (it adds seconds to every process start)."""
    from scipy import signal

    return signal


class ExplorationController(ExtensionPoint, ABC):
    """A controller for the exploration rollout (trial 0). Subclasses take ``u_max``,
    ``action_dim`` and ``rng`` (the system's generator), and ``system`` if they need it.
    Subclass this for your own (``exploration._target_=my_pkg.MyExploration``)."""

    @abstractmethod
    def __call__(self, measurement: np.ndarray, step: int) -> np.ndarray:
        """Action ``[d_u]`` for the reading ``[d_y]`` at control step ``step``."""


class UniformRandomExploration(ExplorationController):
    """u_t ~ U(−u_max, u_max), independently per step and component (thesis §2.5).

    Args:
        u_max: bound of the uniform distribution.
        action_dim: d_u.
        rng: random source (the system's).
    """

    def __init__(self, u_max: float, action_dim: int, rng: np.random.Generator) -> None:
        self.u_max = u_max
        self.action_dim = action_dim
        self.rng = rng

    def __call__(self, measurement: np.ndarray, step: int) -> np.ndarray:
        return self.rng.uniform(-self.u_max, self.u_max, size=self.action_dim)


class SumOfSinesExploration(ExplorationController):
    """u(t) = Σ_k a_k sin(2π f_k t + φ_k) per action component (thesis §3.3), with random
    amplitudes normalised to Σ_k a_k = ``amplitude`` (so |u| ≤ amplitude ≤ u_max),
    frequencies f_k ~ U(``min_frequency_hz``, ``max_frequency_hz``), phases ~ U(0, 2π),
    all drawn once from ``rng``.

    Args:
        u_max: action bound. action_dim: d_u. rng: random source (the system's).
        dt: sampling time in s. num_sines: terms per component.
        amplitude: peak bound of the sum (default u_max).
        equal_amplitudes: every term gets amplitude / num_sines (the DF Furuta's "ten
            cosine waves of random frequencies and same amplitudes", §4.4.1).
    """

    def __init__(
        self,
        u_max: float,
        action_dim: int,
        rng: np.random.Generator,
        dt: float,
        num_sines: int = 10,
        min_frequency_hz: float = 0.1,
        max_frequency_hz: float = 2.0,
        amplitude: float | None = None,
        equal_amplitudes: bool = False,
    ) -> None:
        if num_sines < 1 or not 0 <= min_frequency_hz < max_frequency_hz < 0.5 / dt:
            raise ConfigError(
                f"exploration needs num_sines >= 1 and 0 <= min_frequency_hz < "
                f"max_frequency_hz < {0.5 / dt:g} Hz (Nyquist), got {num_sines}, "
                f"{min_frequency_hz}, {max_frequency_hz}"
            )
        peak = u_max if amplitude is None else min(amplitude, u_max)
        weights = rng.uniform(0.0, 1.0, size=(action_dim, num_sines))
        if equal_amplitudes:
            weights = np.ones_like(weights)
        self.amplitudes = peak * weights / weights.sum(-1, keepdims=True)
        self.frequencies = rng.uniform(min_frequency_hz, max_frequency_hz, (action_dim, num_sines))
        self.phases = rng.uniform(0.0, 2 * np.pi, size=(action_dim, num_sines))
        self.dt = dt

    def __call__(self, measurement: np.ndarray, step: int) -> np.ndarray:
        time = step * self.dt
        waves = np.sin(2 * np.pi * self.frequencies * time + self.phases)
        return (self.amplitudes * waves).sum(-1)


class FilteredNoiseExploration(ExplorationController):
    """Gaussian white noise through a Butterworth low-pass at ``cutoff_hz`` (thesis §4.2),
    scaled so that the filtered signal's stationary std is ``std``; clipped to ±u_max.

    Args:
        u_max: action bound. action_dim: d_u. rng: random source (the system's).
        dt: sampling time in s. cutoff_hz: low-pass cut-off. std: output std (default
        u_max / 2). order: filter order.
    """

    def __init__(
        self,
        u_max: float,
        action_dim: int,
        rng: np.random.Generator,
        dt: float,
        cutoff_hz: float = 1.5,
        std: float | None = None,
        order: int = 2,
    ) -> None:
        if not 0 < cutoff_hz < 0.5 / dt:
            raise ConfigError(
                f"exploration.cutoff_hz={cutoff_hz} must be in (0, {0.5 / dt:g}) Hz (Nyquist)"
            )
        self.b, self.a = _signal().butter(order, cutoff_hz, fs=1.0 / dt)
        impulse = _signal().lfilter(
            self.b, self.a, np.r_[1.0, np.zeros(int(20 / (cutoff_hz * dt)))]
        )
        self.input_std = (u_max / 2 if std is None else std) / np.sqrt(np.sum(impulse**2))
        self.state = np.zeros((action_dim, max(len(self.a), len(self.b)) - 1))
        self.u_max, self.action_dim, self.rng = u_max, action_dim, rng

    def __call__(self, measurement: np.ndarray, step: int) -> np.ndarray:
        noise = self.input_std * self.rng.standard_normal((self.action_dim, 1))
        output, self.state = _signal().lfilter(self.b, self.a, noise, axis=-1, zi=self.state)
        return np.clip(output[:, 0], -self.u_max, self.u_max)


class TriangularWaveExploration(ExplorationController):
    """A triangular wave plus white noise per action component (thesis §3.4.2's exploration
    of the ball-and-plate), clipped to ±u_max. Each component's period is drawn from
    U(``min_period_s``, ``max_period_s``) and its phase from U(0, 1) periods, once.

    With ``integrated`` the wave is the running sum of the actions instead — for an action
    that is a change of a position reference (the ball-and-plate's motor-angle steps) the
    noisy triangle is then the reference itself (a plate tilted back and forth) and the
    action its change per step, clipped to ±u_max; the action's own triangle would sum to
    parabolic swings that tilt the plate far and throw the ball off at once.

    Args:
        u_max: action bound. action_dim: d_u. rng: random source (the system's).
        dt: sampling time in s. amplitude: peak of the wave (default u_max / 2), in units of
            the action, or of its sum with ``integrated``.
        noise_std: std of the added white noise (default amplitude / 4).
        integrated: the wave is the sum of the actions (see above); it starts at zero.
    """

    def __init__(
        self,
        u_max: float,
        action_dim: int,
        rng: np.random.Generator,
        dt: float,
        amplitude: float | None = None,
        noise_std: float | None = None,
        min_period_s: float = 0.5,
        max_period_s: float = 2.0,
        integrated: bool = False,
    ) -> None:
        if not 2 * dt <= min_period_s <= max_period_s:
            raise ConfigError(
                f"exploration needs 2 dt <= min_period_s <= max_period_s, got dt={dt}, "
                f"{min_period_s}, {max_period_s}"
            )
        if amplitude is None:
            self.amplitude = u_max / 2
        else:
            self.amplitude = amplitude if integrated else min(amplitude, u_max)
        self.noise_std = self.amplitude / 4 if noise_std is None else noise_std
        self.periods = rng.uniform(min_period_s, max_period_s, size=action_dim)
        self.integrated = integrated
        # integrated: the wave starts at 0 (a quarter period in), so the reference starts level
        self.phases = np.full(action_dim, 0.25) if integrated else rng.uniform(0.0, 1.0, action_dim)
        self.u_max, self.action_dim, self.rng, self.dt = u_max, action_dim, rng, dt
        self.applied = np.zeros(action_dim)  # integrated: the sum of the actions so far

    def wave(self, step: int) -> np.ndarray:
        """The noise-free triangle at ``step``, ``[d_u]``: −A … A … −A over a period."""
        cycle = np.remainder(step * self.dt / self.periods + self.phases, 1.0)
        return self.amplitude * (4 * np.abs(cycle - 0.5) - 1)

    def __call__(self, measurement: np.ndarray, step: int) -> np.ndarray:
        noise = self.noise_std * self.rng.standard_normal(self.action_dim)
        if not self.integrated:
            return np.clip(self.wave(step) + noise, -self.u_max, self.u_max)
        if step == 0:
            self.applied = np.zeros(self.action_dim)
        target = self.wave(step + 1) + noise  # where the reference should be after this step
        action = np.clip(target - self.applied, -self.u_max, self.u_max)
        self.applied = self.applied + action
        return action
