"""How the runners end a failed run: one line for the errors that say everything, the
traceback in the run directory's ``failed.txt``."""

from __future__ import annotations

import logging
import traceback
from pathlib import Path

from mcpilco.errors import (
    CheckpointError,
    ConfigError,
    NonFiniteError,
    NotPositiveDefiniteError,
    RunInUseError,
    SimulationError,
)
from mcpilco.run_storage import RunDirectory

log = logging.getLogger("mcpilco.runner")


def record_failure(run_dir: Path, error: BaseException) -> None:
    """Write ``failed.txt`` (the traceback) into ``run_dir`` unless another process has
    taken the directory since."""
    if not run_dir.is_dir():
        return
    storage = RunDirectory(run_dir)
    text = "".join(traceback.format_exception(type(error), error, error.__traceback__))
    try:
        with storage.locked():
            storage.record_failure(text)
    except RunInUseError:
        log.warning("%s was taken by another process; failed.txt not written", run_dir)


EXPECTED_ERRORS: tuple[type[Exception], ...] = (
    ConfigError,
    NonFiniteError,
    SimulationError,
    NotPositiveDefiniteError,
    CheckpointError,
)
"""Failures with a one-line message that says everything: logged as that line (the
traceback goes to ``failed.txt``), exit status 2 for a bad config and 1 otherwise."""
