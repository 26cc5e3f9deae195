"""A joint reference read from a file (``reference=file reference.path=...``).

Formats (read as data, never executed):

* ``.csv``: one row per sample, comma-separated, an optional header line; columns
  ``t, q_1..q_n`` and optionally ``q̇_1..q̇_n`` and then ``q̈_1..q̈_n`` (1 + n, 1 + 2n or
  1 + 3n columns).
* ``.npz``: arrays ``time [T]``, ``positions [T, n]`` and optionally ``velocities`` and
  ``accelerations`` ``[T, n]`` (``numpy.load(allow_pickle=False)``).

Time in s, strictly increasing, shifted to start at 0; positions in rad. Between samples
(the 1 kHz control steps) and for the derivatives a file does not hold:

* positions only: a cubic spline through the positions (``scipy.interpolate.CubicSpline``,
  not-a-knot ends) gives r, and its first and second derivatives give ṙ and r̈;
* positions and velocities: the cubic Hermite spline through both
  (``CubicHermiteSpline``) gives r and ṙ, its second derivative r̈;
* all three: r and ṙ from the Hermite spline, r̈ linear between the given samples.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mcpilco.checks import number
from mcpilco.control.reference_families import ReferenceFamily
from mcpilco.control.references import Reference
from mcpilco.errors import ConfigError

MIN_SAMPLES = 4
"""The not-a-knot cubic spline needs four samples."""


@dataclass(frozen=True)
class FileReference(Reference):
    """Samples ``time [T]`` (s, from 0), ``positions [T, n]`` and optional ``velocities``,
    ``accelerations`` ``[T, n]``, interpolated as the module says."""

    time: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray | None
    accelerations: np.ndarray | None
    duration: float
    label: str = "file"

    @property
    def num_joints(self) -> int:
        return self.positions.shape[1]

    def __call__(self, time: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        from scipy.interpolate import CubicHermiteSpline, CubicSpline

        t = np.asarray(time, dtype=np.float64)
        if self.velocities is None:
            spline = CubicSpline(self.time, self.positions, axis=0, bc_type="not-a-knot")
        else:
            spline = CubicHermiteSpline(self.time, self.positions, self.velocities, axis=0)
        r, rd = spline(t), spline(t, 1)
        if self.accelerations is None:
            rdd = spline(t, 2)
        else:
            rdd = np.stack([np.interp(t, self.time, a) for a in self.accelerations.T], axis=-1)
        return r, rd, rdd

    def parameters(self) -> dict[str, np.ndarray]:
        return {"file_time": self.time, "file_positions": self.positions}


class TrajectoryFile(ReferenceFamily):
    """One reference from a ``.csv`` or ``.npz`` file (format: the module's docstring).

    Args:
        path: the file (relative paths: to the working directory).
        duration: s to track (null: the file's whole span; at most that span).
        label: the reference's name in the run (null: the file's stem).
    """

    def __init__(self, path: str, duration: float | None = None, label: str | None = None) -> None:
        if not isinstance(path, str) or not path.strip():
            raise ConfigError(f"reference.path={path!r} must name a .csv or .npz file")
        self.path = Path(path)
        if self.path.suffix.lower() not in (".csv", ".npz"):
            raise ConfigError(f"reference.path={path!r} must be a .csv or .npz file")
        self.duration = (
            None if duration is None else number("reference.duration", duration, above=0)
        )
        stem = "".join(c if c.isalnum() or c in "_-." else "_" for c in self.path.stem)
        self.label = label if label is not None else (stem or "file")

    def _read(self) -> tuple[np.ndarray, ...]:
        key = f"reference.path={str(self.path)!r}"
        if not self.path.is_file():
            raise ConfigError(f"{key}: no such file")
        try:
            if self.path.suffix.lower() == ".npz":
                with np.load(self.path, allow_pickle=False) as arrays:
                    missing = [k for k in ("time", "positions") if k not in arrays.files]
                    if missing:
                        raise ConfigError(
                            f"{key} has no {missing[0]!r} array (it has {arrays.files})"
                        )
                    columns = [np.asarray(arrays["time"], dtype=np.float64)[:, None]]
                    for name in ("positions", "velocities", "accelerations"):
                        if name in arrays.files:
                            columns.append(
                                np.atleast_2d(np.asarray(arrays[name], dtype=np.float64))
                            )
                    table = np.concatenate(
                        [c if c.shape[0] == columns[0].shape[0] else c.T for c in columns], axis=1
                    )
            else:
                text = self.path.read_text(encoding="utf-8").splitlines()
                rows = [line for line in text if line.strip() and not line.lstrip().startswith("#")]
                first = rows[0].split(",")[0].strip() if rows else ""
                try:
                    float(first)
                except ValueError:
                    rows = rows[1:]  # a header line
                table = np.array([[float(v) for v in row.split(",")] for row in rows], ndmin=2)
        except ConfigError:
            raise
        except (ValueError, OSError, UnicodeDecodeError, EOFError) as error:
            reason = (
                str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
            )
            raise ConfigError(f"{key} is not a readable trajectory ({reason[:120]})") from None
        return table  # type: ignore[return-value]

    def references(self, num_joints: int) -> list[Reference]:
        key = f"reference.path={str(self.path)!r}"
        table = self._read()
        columns = table.shape[1] - 1 if table.ndim == 2 else 0
        if table.ndim != 2 or columns not in (num_joints, 2 * num_joints, 3 * num_joints):
            raise ConfigError(
                f"{key} has {columns} value columns after the time; the robot has {num_joints} "
                f"joints: give {num_joints} (q), {2 * num_joints} (q, q̇) or {3 * num_joints} "
                "(q, q̇, q̈)"
            )
        if len(table) < MIN_SAMPLES:
            raise ConfigError(f"{key} has {len(table)} samples; at least {MIN_SAMPLES} are needed")
        bad = np.argwhere(~np.isfinite(table))
        if bad.size:
            row, column = (int(v) for v in bad[0])
            raise ConfigError(
                f"{key}: sample {row}, column {column} is {table[row, column]} (not finite)"
            )
        time = table[:, 0] - table[0, 0]
        steps = np.diff(time)
        if np.any(steps <= 0):
            row = int(np.flatnonzero(steps <= 0)[0]) + 1
            raise ConfigError(
                f"{key}: time must increase strictly; sample {row} is at {table[row, 0]} s after "
                f"{table[row - 1, 0]} s"
            )
        span = float(time[-1])
        duration = span if self.duration is None else self.duration
        if duration > span + 1e-12:
            raise ConfigError(
                f"reference.duration={duration} is longer than the file's {span:g} s ({key})"
            )
        n = num_joints
        values = table[:, 1:]
        velocities = values[:, n : 2 * n] if columns >= 2 * n else None
        accelerations = values[:, 2 * n :] if columns == 3 * n else None
        return [FileReference(time, values[:, :n], velocities, accelerations, duration, self.label)]
