"""What a system's sensors return: a subset of the state, noisy and possibly quantised."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch

from mcpilco.errors import ConfigError


class Sensors:
    """Measures state components ``measured`` (d_y of the d_x) with additive Gaussian
    noise and, optionally, quantisation to a resolution (e.g. an encoder's 2π/4096 rad).

    On the system a reading is ``round((x[measured] + e) / r) · r``; on simulated particles
    (MC-PILCO4PMS, DF-MC-PILCO) the quantisation becomes the fictitious uniform noise
    U(−r/2, r/2) of thesis §4.4, so the reading stays differentiable.

    Args:
        state_dim: d_x.
        measured: state indices that are measured, in reading order (None: all).
        noise_std: std of the Gaussian noise, one per measured component or one for all
            (units of the components).
        resolution: quantisation step per measured component or one for all; None or 0
            for none.
        allow_exact: accept ``noise_std`` 0 (exact readings, e.g. a simulated benchmark's
            observation); otherwise the noise must be > 0.
    """

    def __init__(
        self,
        state_dim: int,
        measured: Sequence[int] | None = None,
        noise_std: float | Sequence[float] = 1e-2,
        resolution: float | Sequence[float] | None = None,
        allow_exact: bool = False,
    ) -> None:
        self.state_dim = state_dim
        indices = tuple(range(state_dim)) if measured is None else tuple(int(i) for i in measured)
        if (
            not indices
            or len(set(indices)) != len(indices)
            or not all(0 <= i < state_dim for i in indices)
        ):
            raise ConfigError(
                f"system.measured_indices must be distinct indices in [0, {state_dim}), "
                f"got {measured!r}"
            )
        self.measured = indices
        self.noise_std = self._per_reading("measurement_noise_std", noise_std)
        if np.any(self.noise_std < 0) or (not allow_exact and np.any(self.noise_std == 0)):
            bound = ">= 0" if allow_exact else "> 0"
            raise ConfigError(f"system.measurement_noise_std must be {bound}, got {noise_std!r}")
        self.resolution = self._per_reading(
            "quantization", 0.0 if resolution is None else resolution
        )
        if np.any(self.resolution < 0):
            raise ConfigError(f"system.quantization must be >= 0, got {resolution!r}")
        self._cache: dict[tuple[torch.dtype, torch.device], tuple[torch.Tensor, torch.Tensor]] = {}

    def _per_reading(self, name: str, value: float | Sequence[float]) -> np.ndarray:
        array = np.asarray(value, dtype=np.float64)
        if array.ndim > 1 or array.size not in (1, len(self.measured)):
            raise ConfigError(
                f"system.{name} needs one value or {len(self.measured)} (one per measured "
                f"component), got {value!r}"
            )
        if not np.all(np.isfinite(array)):
            raise ConfigError(f"system.{name} must be finite, got {value!r}")
        return np.broadcast_to(array, (len(self.measured),)).copy()

    @property
    def reading_dim(self) -> int:
        """d_y."""
        return len(self.measured)

    @property
    def measures_everything(self) -> bool:
        """True when every state component is read, in state order."""
        return self.measured == tuple(range(self.state_dim))

    @property
    def quantised(self) -> bool:
        return bool(np.any(self.resolution > 0))

    def read(self, state: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The reading ``[d_y]`` of a true state ``[d_x]``."""
        reading = state[list(self.measured)] + self.noise_std * rng.standard_normal(
            self.reading_dim
        )
        if self.quantised:
            step = np.where(self.resolution > 0, self.resolution, 1.0)
            reading = np.where(self.resolution > 0, np.round(reading / step) * step, reading)
        return reading

    def variance(self) -> np.ndarray:
        """Variance of the reading error per component ``[d_y]``: σ² + r²/12."""
        return self.noise_std**2 + self.resolution**2 / 12.0

    def simulate(
        self, states: torch.Tensor, gaussian: torch.Tensor, uniform: torch.Tensor | None
    ) -> torch.Tensor:
        """Simulated readings ``[M, d_y]`` of particles ``[M, d_x]`` (differentiable).

        Args:
            gaussian: standard normal ``[M, d_y]``.
            uniform: U(0, 1) ``[M, d_y]`` for the quantisation noise (None: not quantised).
        """
        noise_std, resolution = self._tensors(states.dtype, states.device)
        reading = states[:, list(self.measured)] + noise_std * gaussian
        if uniform is not None and self.quantised:
            reading = reading + resolution * (uniform - 0.5)
        return reading

    def _tensors(
        self, dtype: torch.dtype, device: torch.device
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """σ and r as tensors, converted once per dtype/device (simulate runs every step)."""
        key = (dtype, device)
        if key not in self._cache:
            self._cache[key] = (
                torch.as_tensor(self.noise_std, dtype=dtype, device=device),
                torch.as_tensor(self.resolution, dtype=dtype, device=device),
            )
        return self._cache[key]
