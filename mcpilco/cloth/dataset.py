"""Cloth movement data sets (thesis §6.4.1): the excitation of eq. 6.12, generation, files.

A data set 𝒟_R holds S sequences of one movement range R: observations ``[S, N, D]``
(vertex coordinates x₁ y₁ z₁ x₂ …, m) and controls ``[S, N−1, E]`` (u_t = command_{t+1} −
command_t of both end-effectors, m). Sequence k of (seed, R) is drawn from its own random
stream, so any subset can be simulated alone and equals the same sequences of the whole set.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mcpilco.cloth.simulation import ClothSimulation
from mcpilco.errors import ConfigError


@dataclass(frozen=True)
class Excitation:
    """Eq. 6.12: δX = 0, δY = −A cos γ cos 2πf_Y t, δZ = A sin γ cos 2πf_Z t.

    Attributes:
        amplitude: A, m per step.
        frequency_range: (low, high) of the uniform f_Y, f_Z, Hz.
        num_samples: N observations per sequence (N − 1 controls).
    """

    amplitude: float = 0.01
    frequency_range: tuple[float, float] = (0.3, 0.6)
    num_samples: int = 60

    def facts(self) -> dict[str, Any]:
        """What a data set records of its excitation (and is compared against)."""
        return {
            "amplitude": float(self.amplitude),
            "frequency_range": [float(f) for f in self.frequency_range],
            "num_samples": int(self.num_samples),
        }

    def draw(self, rng: np.random.Generator, range_deg: float) -> dict[str, float]:
        """γ ~ U(−R/2, R/2) deg and f_Y, f_Z ~ U(frequency_range)."""
        low, high = self.frequency_range
        return {
            "gamma_deg": float(rng.uniform(-range_deg / 2.0, range_deg / 2.0)),
            "f_y": float(rng.uniform(low, high)),
            "f_z": float(rng.uniform(low, high)),
        }

    def displacements(self, parameters: dict[str, float], sample_dt: float) -> np.ndarray:
        """Common displacements ``[N−1, 3]`` (m) at t = 0, Δt, …, (N−2)Δt."""
        time = np.arange(self.num_samples - 1) * sample_dt
        gamma = np.radians(parameters["gamma_deg"])
        return np.stack(
            [
                np.zeros_like(time),
                -self.amplitude * np.cos(gamma) * np.cos(2 * np.pi * parameters["f_y"] * time),
                self.amplitude * np.sin(gamma) * np.cos(2 * np.pi * parameters["f_z"] * time),
            ],
            axis=1,
        )


@dataclass
class ClothDataset:
    """Sequences of one movement range (or read from CSV files).

    Attributes:
        observations: ``[S, N, D]`` vertex coordinates, m.
        controls: ``[S, N−1, E]`` end-effector displacements, m.
        indices: the sequence number of each row within its data set ``[S]``.
        metadata: range_deg, seed, cloth fingerprint, excitation, per-sequence γ, f_Y, f_Z.
    """

    observations: np.ndarray
    controls: np.ndarray
    indices: np.ndarray
    metadata: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.observations.ndim != 3 or self.controls.ndim != 3:
            raise ConfigError(
                f"data set: observations {self.observations.shape} must be [S, N, D] and "
                f"controls {self.controls.shape} [S, N-1, E]"
            )
        s, n, _ = self.observations.shape
        if self.controls.shape[:2] != (s, n - 1) or len(self.indices) != s:
            raise ConfigError(
                f"data set: controls {self.controls.shape} do not match observations "
                f"{self.observations.shape} (want [S, N-1, E]) or indices {len(self.indices)}"
            )
        for name in ("observations", "controls"):
            if not np.all(np.isfinite(getattr(self, name))):
                raise ConfigError(f"data set: {name} hold NaN or infinite values")

    def subset(self, rows: Sequence[int]) -> ClothDataset:
        rows = list(rows)
        return ClothDataset(
            self.observations[rows], self.controls[rows], self.indices[rows], self.metadata
        )

    def save(self, path: Path) -> None:
        """``path`` (.npz of arrays only) beside ``path.with_suffix('.json')``. Both are
        written beside their names first; the ``.json`` is renamed into place before the
        ``.npz``, so a ``.npz`` on disk always has its ``.json`` (a kill in between leaves a
        ``.json`` alone, which the next save replaces)."""
        path.parent.mkdir(parents=True, exist_ok=True)
        partial = path.with_name(f".{path.name}.partial.npz")
        meta, meta_partial = path.with_suffix(".json"), path.with_name(f".{path.stem}.partial.json")
        np.savez(
            partial, observations=self.observations, controls=self.controls, indices=self.indices
        )
        meta_partial.write_text(json.dumps(self.metadata, indent=1))
        meta_partial.replace(meta)
        partial.replace(path)

    @classmethod
    def load(cls, path: Path) -> ClothDataset:
        """Read what :meth:`save` wrote (no pickles); a clear error on a damaged file."""
        try:
            with np.load(path, allow_pickle=False) as arrays:
                observations, controls = arrays["observations"], arrays["controls"]
                indices = arrays["indices"]
            metadata = json.loads(path.with_suffix(".json").read_text())
        except (OSError, ValueError, KeyError) as error:
            raise ConfigError(f"data set {path} cannot be read: {error}") from None
        return cls(observations, controls, indices, metadata)


def sequence_rng(seed: int, range_deg: float, index: int) -> np.random.Generator:
    """The random stream of sequence ``index`` of data set (seed, R)."""
    return np.random.default_rng(np.random.SeedSequence([seed, round(range_deg * 1000), index]))


def generate(
    simulation: ClothSimulation,
    excitation: Excitation,
    range_deg: float,
    seed: int,
    indices: Sequence[int],
) -> ClothDataset:
    """Simulate sequences ``indices`` of data set (seed, R), all from the rest configuration."""
    if not np.isfinite(range_deg) or not 0 < range_deg <= 360:
        raise ConfigError(f"data.range_deg={range_deg!r} must be in (0, 360]")
    sample_dt = simulation.parameters.sample_dt
    observations, controls, draws = [], [], []
    for index in indices:
        draw = excitation.draw(sequence_rng(seed, range_deg, index), range_deg)
        displacements = excitation.displacements(draw, sample_dt)
        control = np.concatenate([displacements, displacements], axis=1)
        vertices, _ = simulation.run(control)
        observations.append(vertices.reshape(len(vertices), -1))
        controls.append(control)
        draws.append(draw)
    metadata = {
        "source": "mcpilco.cloth simulation",
        "range_deg": float(range_deg),
        "seed": int(seed),
        "cloth": simulation.parameters.fingerprint(),
        "excitation": excitation.facts(),
        "draws": dict(zip([str(i) for i in indices], draws, strict=True)),
    }
    return ClothDataset(
        np.stack(observations), np.stack(controls), np.asarray(list(indices)), metadata
    )


def read_csv_sequences(directory: Path, duplicate_controls: bool = False) -> ClothDataset:
    """Sequences in the CSV layout of the authors' public CGPDM library: for each k,
    ``state_samples_*_k.csv`` (rows t: x₁ y₁ z₁ x₂ … of every point) and
    ``input_samples_*_k.csv`` (rows t: the end-effector displacement). Rows of the input
    file beyond N − 1 are ignored; ``duplicate_controls`` turns a 3-column displacement into
    the 6-column control of two end-effectors."""
    states = sorted(directory.glob("state_samples*.csv"), key=_trailing_number)
    if not states:
        raise ConfigError(f"data.csv_dir={str(directory)!r} holds no state_samples*.csv files")
    observations, controls, indices = [], [], []
    for state_path in states:
        number = _trailing_number(state_path)
        input_path = state_path.with_name(state_path.name.replace("state_samples", "input_samples"))
        if not input_path.exists():
            raise ConfigError(f"data.csv_dir: {state_path.name} has no {input_path.name}")
        y = np.loadtxt(state_path, delimiter=",", ndmin=2)
        u = np.loadtxt(input_path, delimiter=",", ndmin=2)
        if len(u) < len(y) - 1:
            raise ConfigError(f"{input_path.name}: {len(u)} rows, need {len(y) - 1}")
        u = u[: len(y) - 1]
        observations.append(y)
        controls.append(np.concatenate([u, u], axis=1) if duplicate_controls else u)
        indices.append(number)
    lengths = {len(y) for y in observations}
    if len(lengths) != 1:
        raise ConfigError(f"data.csv_dir: sequences differ in length {sorted(lengths)}")
    return ClothDataset(
        np.stack(observations),
        np.stack(controls),
        np.asarray(indices),
        {"source": f"csv:{directory}"},
    )


def _trailing_number(path: Path) -> int:
    digits = path.stem.rsplit("_", 1)[-1]
    if not digits.isdigit():
        raise ConfigError(f"{path.name}: the file name must end in _<number>.csv")
    return int(digits)
