"""A run directory on disk: resolved config, per-trial summary, data and checkpoints.

Everything of a unit (a trial, a reference seed, a test sequence) is written as soon as it
ends, each file atomically (written beside its final name, then renamed), so a crash or
Ctrl-C never loses a finished unit; ``summary.csv`` holds one row per finished unit, keyed
(:meth:`RunDirectory.append_summary`). What a rerun of a directory means is decided once, for
every runner, in :mod:`mcpilco.run_contract`.
Checkpoints hold state dicts of tensors only and are read with ``weights_only=True``.
A live run holds an advisory lock on its directory (:meth:`RunDirectory.locked`).
"""

from __future__ import annotations

import json
import logging
import os
import pickle
import shutil
import socket
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import torch

from mcpilco.errors import CheckpointError, RunFileError, RunInUseError
from mcpilco.trajectory import Trajectory

try:
    import fcntl
except ImportError:  # not POSIX: no advisory lock
    fcntl = None  # type: ignore[assignment]

log = logging.getLogger(__name__)

RESUME_OVERRIDES = ("num_trials", "threads", "device", "compile", "compile_steps")
"""Top-level config keys a resumed run (``runners.train resume=DIR``) takes from the
command line (when given there) instead of its saved config: how many trials, and the
machine it runs on."""
MACHINE_KEYS = (*RESUME_OVERRIDES, "resume", "overwrite")
"""Top-level config keys that do not make a run another experiment (a resumed run's check
of its config, :mod:`analysis.study_tags`)."""


def _atomic_path(path: Path) -> Path:
    return path.with_name(f".{path.name}.partial")


class RunDirectory:
    """Files of one run.

    Layout::

        config.yaml                  resolved config (written by the runner)
        summary.csv                  one row per trial (trial 0 = exploration)
        trajectories/trial_KK.npz    states, measurements, actions, dt
        optimization/trial_KK.csv    Ĵ, p_d, α_lr, s per optimisation step
        checkpoints/trial_KK/model.pt, policy.pt   state dicts
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        self.path.mkdir(parents=True, exist_ok=True)

    def _write(self, path: Path, write: Any) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        partial = _atomic_path(path)
        write(partial)
        os.replace(partial, path)

    def write_text(self, name: str, text: str) -> None:
        self._write(self.path / name, lambda p: p.write_text(text))

    def save_trajectory(self, trial: int, trajectory: Trajectory) -> None:
        def write(p: Path) -> None:
            with open(p, "wb") as handle:
                np.savez(handle, **trajectory.as_arrays())

        self._write(self.path / "trajectories" / f"trial_{trial:02d}.npz", write)

    def save_arrays(self, name: str, arrays: Mapping[str, np.ndarray]) -> None:
        """``name`` (a relative ``.npz`` path) holding ``arrays``, written atomically."""

        def write(p: Path) -> None:
            with open(p, "wb") as handle:
                np.savez(handle, **arrays)

        self._write(self.path / name, write)

    def load_trajectory(self, trial: int) -> Trajectory:
        with np.load(self.path / "trajectories" / f"trial_{trial:02d}.npz") as arrays:
            return Trajectory.from_arrays(dict(arrays))

    def save_optimization_trace(self, trial: int, trace: Mapping[str, list[float]]) -> None:
        frame = pd.DataFrame(trace)
        frame.index.name = "step"
        self._write(
            self.path / "optimization" / f"trial_{trial:02d}.csv", lambda p: frame.to_csv(p)
        )

    def save_tensors(self, name: str, state: Mapping[str, torch.Tensor]) -> None:
        """A dict of tensors (moved to the CPU) at the relative path ``name``, atomically."""
        tensors = {key: value.detach().cpu() for key, value in state.items()}
        self._write(self.path / name, lambda p: torch.save(tensors, p))

    def save_checkpoint(self, trial: int, name: str, state: Mapping[str, torch.Tensor]) -> None:
        self.save_tensors(f"checkpoints/trial_{trial:02d}/{name}.pt", state)

    def load_checkpoint(self, trial: int, name: str) -> dict[str, torch.Tensor]:
        return load_tensors(self.path / "checkpoints" / f"trial_{trial:02d}" / f"{name}.pt")

    def save_random_state(self, trial: int, state: Mapping[str, Any]) -> None:
        """Generator states after ``trial`` (numpy's as JSON, torch's as tensors)."""
        folder = self.path / "checkpoints" / f"trial_{trial:02d}"
        tensors = {k: v for k, v in state.items() if isinstance(v, torch.Tensor)}
        others = {k: v for k, v in state.items() if not isinstance(v, torch.Tensor)}
        self._write(folder / "random.pt", lambda p: torch.save(tensors, p))
        self._write(folder / "random.json", lambda p: p.write_text(json.dumps(others)))

    def load_random_state(self, trial: int) -> dict[str, Any]:
        folder = self.path / "checkpoints" / f"trial_{trial:02d}"
        state: dict[str, Any] = json.loads((folder / "random.json").read_text())
        state.update(load_tensors(folder / "random.pt"))
        return state

    def finished_trials(self) -> int:
        """Number of the last trial whose files are all on disk (−1 when none)."""
        trials = self.finished_units("trial")
        if trials != list(range(len(trials))):
            raise RunFileError(f"{self.path / 'summary.csv'}: trials {trials} are not 0, 1, 2, ...")
        return len(trials) - 1

    def finished_units(self, key: str) -> list[Any]:
        """The ``key`` column of ``summary.csv``: the finished units (trials, reference
        seeds, sequences), in order; empty when there is no summary yet."""
        if not (self.path / "summary.csv").exists():
            return []
        table = self.summary()
        if key not in table.columns:
            raise RunFileError(f"{self.path / 'summary.csv'} has no {key!r} column")
        return table[key].tolist()

    def append_summary(self, row: Mapping[str, Any], key: str = "trial") -> pd.DataFrame:
        """Add one unit's row to ``summary.csv`` and return the whole table. A row whose
        ``key`` is already there replaces it (a unit is never listed twice)."""
        path = self.path / "summary.csv"
        table = self.summary() if path.exists() else pd.DataFrame()
        if key in table.columns:
            table = table[table[key] != row[key]]
        table = pd.concat([table, pd.DataFrame([dict(row)])], ignore_index=True)
        self._write(path, lambda p: table.to_csv(p, index=False))
        return table

    def summary(self) -> pd.DataFrame:
        """``summary.csv``; :class:`RunFileError` (one line naming the file) when it is
        missing, empty or not a table."""
        path = self.path / "summary.csv"
        try:
            return pd.read_csv(path)
        except FileNotFoundError:
            raise RunFileError(f"{path} does not exist (no unit finished yet)") from None
        except (pd.errors.EmptyDataError, pd.errors.ParserError, UnicodeDecodeError) as error:
            reason = str(error).strip().splitlines()[0] if str(error).strip() else "empty"
            raise RunFileError(
                f"{path} is not a readable table ({reason}); delete it to redo the run's "
                "units, or pass overwrite=true"
            ) from None

    FAILURE_FILE = "failed.txt"

    def record_failure(self, text: str) -> None:
        """Mark the run as failed (a sweep's analysis lists it) with the error's text."""
        self.write_text(self.FAILURE_FILE, text)

    def clear_failure(self) -> None:
        (self.path / self.FAILURE_FILE).unlink(missing_ok=True)

    @property
    def failed(self) -> bool:
        return (self.path / self.FAILURE_FILE).is_file()

    LOCK_FILE = ".mcpilco.lock"

    @contextmanager
    def locked(self, wait: bool = False) -> Iterator[None]:
        """Hold the directory's advisory lock (``flock``) for the block; a second process
        asking for it gets :class:`RunInUseError` at once (or, with ``wait``, blocks until
        the holder is done). The kernel releases the lock when its process ends, however
        it ends, so a killed run never leaves it stuck."""
        if fcntl is None:
            log.warning("no advisory locks on this platform: %s is not protected", self.path)
            yield
            return
        handle = open(self.path / self.LOCK_FILE, "a+")  # noqa: SIM115 (closed below)
        try:
            fcntl.flock(handle, fcntl.LOCK_EX if wait else fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.seek(0)
            holder = handle.read().strip() or "another process"
            handle.close()
            raise RunInUseError(
                f"{self.path} is in use by {holder}: wait for it to end, or pick another "
                "directory (hydra.run.dir=...)"
            ) from None
        try:
            handle.seek(0)
            handle.truncate()
            handle.write(f"pid {os.getpid()} on {socket.gethostname()}\n")
            handle.flush()
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)
            handle.close()

    def clear(self) -> None:
        """Delete everything a run wrote here (results, logs of trials, checkpoints), keeping
        Hydra's ``.hydra/``, the ``*.log`` files of the current start and the lock."""
        for entry in self.path.iterdir():
            if entry.name in (".hydra", self.LOCK_FILE) or entry.suffix == ".log":
                continue
            if entry.is_dir():
                shutil.rmtree(entry)
            else:
                entry.unlink()


def load_tensors(path: Path) -> dict[str, Any]:
    """A checkpoint's dict of tensors, read with ``weights_only=True`` (nothing in it runs);
    :class:`CheckpointError`, one line naming the file, when it is missing, corrupt or holds
    anything else."""
    if not path.is_file():
        raise CheckpointError(f"{path} does not exist")
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except pickle.UnpicklingError as error:
        first = str(error).strip().splitlines()
        reason = next((line for line in first if "unsupported" in line.lower()), "not tensors")
        raise CheckpointError(
            f"{path} was refused: it holds more than tensors and containers of them "
            f"({reason.strip()}); mcpilco never loads such a file"
        ) from None
    except (RuntimeError, EOFError, OSError, ValueError) as error:
        lines = str(error).strip().splitlines()
        reason = lines[0].split(". ")[0] if lines else type(error).__name__
        raise CheckpointError(f"{path} is not a readable checkpoint ({reason})") from None
    if not isinstance(state, dict):
        raise CheckpointError(f"{path} holds a {type(state).__name__}, not a dict of tensors")
    return state
