"""How the runners end a failed run: one line for the errors that say everything, the
traceback in the run directory's ``failed.txt``."""

from __future__ import annotations

import logging
import sys
import traceback
from collections.abc import Callable
from pathlib import Path

from hydra.core.hydra_config import HydraConfig
from hydra.types import RunMode

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


def run_reporting_failures(action: Callable[[], None], run_dir: Path, resume_hint: bool) -> None:
    """Run ``action`` (one Hydra job writing into ``run_dir``). A failure leaves
    ``failed.txt`` there (unless another process holds the directory) and, for the errors
    that say everything (:data:`EXPECTED_ERRORS`), one ``ERROR`` line and exit status 2
    (bad config) or 1; in a sweep the error is re-raised so Hydra records the job as failed
    and runs the others. ``resume_hint``: an interruption says how to continue."""
    single = HydraConfig.get().mode != RunMode.MULTIRUN
    try:
        action()
    except RunInUseError as error:  # the directory is another process's: leave it alone
        log.error("%s", error)
        if single:
            sys.exit(2)
        raise
    except (Exception, KeyboardInterrupt) as error:
        record_failure(run_dir, error)
        if isinstance(error, KeyboardInterrupt):
            hint = f": resume={run_dir}" if resume_hint else ""
            log.error("interrupted; the finished trials are kept%s", hint)
            if single:  # the traceback is in failed.txt; the console gets the line alone
                sys.exit(130)
        elif isinstance(error, EXPECTED_ERRORS):
            kind = "configuration error" if isinstance(error, ConfigError) else "run stopped"
            log.error("%s: %s", kind, error)
            if single:
                sys.exit(2 if isinstance(error, ConfigError) else 1)
        raise
