"""Cloth movement data sets (thesis §6.4.1): the excitation of eq. 6.12, generation, files.

A data set 𝒟_R holds S sequences of one movement range R: observations ``[S, N, D]``
(vertex coordinates x₁ y₁ z₁ x₂ …, m) and controls ``[S, N−1, E]`` (u_t = command_{t+1} −
command_t of both end-effectors, m). Sequence k of (seed, R) is drawn from its own random
stream, so any subset can be simulated alone and equals the same sequences of the whole set.
"""

from __future__ import annotations

import json
import warnings
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
    ``input_samples_*_k.csv`` (rows t: the end-effector displacement; its columns are the
    controls). Rows of the input file beyond N − 1 are ignored; ``duplicate_controls``
    turns a 3-column displacement into the 6-column control of two end-effectors.

    Every malformed file is refused in one line naming it, before any training: not
    numbers, no rows, a coordinate count that is not a multiple of 3, column counts or
    lengths that differ between sequences, too few input rows, an input file without its
    state file or the reverse."""
    states = sorted(directory.glob("state_samples*.csv"), key=_trailing_number)
    if not states:
        raise ConfigError(f"data.csv_dir={str(directory)!r} holds no state_samples*.csv files")
    expected_inputs = {
        s.with_name(s.name.replace("state_samples", "input_samples")).name for s in states
    }
    orphans = sorted(p.name for p in directory.glob("input_samples*.csv"))
    orphans = [name for name in orphans if name not in expected_inputs]
    if orphans:
        raise ConfigError(
            f"data.csv_dir: {orphans[0]} has no state_samples file"
            + (f" ({len(orphans)} input files without one)" if len(orphans) > 1 else "")
        )
    observations, controls, indices = [], [], []
    first: tuple[int, int, int] = (0, 0, 0)  # state columns, state rows, input columns
    for state_path in states:
        number = _trailing_number(state_path)
        input_path = state_path.with_name(state_path.name.replace("state_samples", "input_samples"))
        if not input_path.exists():
            raise ConfigError(f"data.csv_dir: {state_path.name} has no {input_path.name}")
        y, u = _numbers(state_path), _numbers(input_path)
        if y.shape[1] % 3:
            raise ConfigError(
                f"{state_path.name}: {y.shape[1]} columns, not x y z of whole points "
                "(a multiple of 3)"
            )
        if not observations:
            first = (y.shape[1], len(y), u.shape[1])
        for file, name, value, wanted in (
            (state_path, "columns", y.shape[1], first[0]),
            (state_path, "rows", len(y), first[1]),
            (input_path, "columns", u.shape[1], first[2]),
        ):
            if value != wanted:
                raise ConfigError(
                    f"{file.name}: {value} {name}, but the first sequence's file has {wanted}"
                )
        if len(u) < len(y) - 1:
            raise ConfigError(f"{input_path.name}: {len(u)} rows, need {len(y) - 1}")
        u = u[: len(y) - 1]
        observations.append(y)
        controls.append(np.concatenate([u, u], axis=1) if duplicate_controls else u)
        indices.append(number)
    return ClothDataset(
        np.stack(observations),
        np.stack(controls),
        np.asarray(indices),
        {"source": f"csv:{directory}"},
    )


def _numbers(path: Path) -> np.ndarray:
    """The rows ``[T, C]`` of a numeric CSV file; one line naming it otherwise."""
    try:
        with warnings.catch_warnings():  # an empty file: reported below, in one line
            warnings.simplefilter("ignore", UserWarning)
            values = np.loadtxt(path, delimiter=",", ndmin=2)
    except (ValueError, OSError, UnicodeDecodeError) as error:
        reason = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise ConfigError(f"{path.name}: not a numeric CSV file ({reason})") from None
    if values.size == 0:
        raise ConfigError(f"{path.name}: no rows")
    return values


def _trailing_number(path: Path) -> int:
    digits = path.stem.rsplit("_", 1)[-1]
    if not digits.isdigit():
        raise ConfigError(f"{path.name}: the file name must end in _<number>.csv")
    return int(digits)
