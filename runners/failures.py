"""How the runners end a failed run: one line for the errors that say everything, the
traceback in the run directory's ``failed.txt``."""

from __future__ import annotations

import logging
import os
import signal
import sys
import threading
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any

from hydra.core.hydra_config import HydraConfig
from hydra.types import RunMode

from mcpilco.errors import (
    CheckpointError,
    ConfigError,
    ForeignRunError,
    NonFiniteError,
    NotPositiveDefiniteError,
    RunFileError,
    RunInUseError,
    SimulationError,
    Terminated,
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
    ForeignRunError,
    NonFiniteError,
    SimulationError,
    NotPositiveDefiniteError,
    CheckpointError,
    RunFileError,
)
"""Failures with a one-line message that says everything: logged as that line (the
traceback goes to ``failed.txt``), exit status 2 for a bad config and 1 otherwise."""


def handle_signals() -> None:
    """SIGTERM (what Slurm, Ray and Kubernetes send before a kill) raises
    :class:`Terminated`, handled like Ctrl-C; a second Ctrl-C or SIGTERM while the first is
    being handled ends the process at once (every file is written atomically, so nothing
    finished is lost) instead of printing a traceback from the clean-up. Only in the main
    thread (elsewhere the process's own handlers stay)."""
    if threading.current_thread() is not threading.main_thread():
        return
    state = {"seen": False}

    def stop(signum: int, frame: Any) -> None:
        if state["seen"]:
            log.error("interrupted again: exiting now (finished units are on disk)")
            logging.shutdown()
            os._exit(128 + signum)
        state["seen"] = True
        raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()

    signal.signal(signal.SIGINT, stop)
    signal.signal(signal.SIGTERM, stop)


def run_reporting_failures(action: Callable[[], None], run_dir: Path, unit: str = "trial") -> None:
    """Run ``action`` (one Hydra job writing into ``run_dir``). A failure leaves
    ``failed.txt`` there (unless another process holds the directory, or it holds another
    run: :class:`ForeignRunError`) and, for the errors that say everything
    (:data:`EXPECTED_ERRORS`), one ``ERROR`` line and exit status 2 (bad config) or 1; in a
    sweep the error is re-raised so Hydra records the job as failed and runs the others.
    An interruption (Ctrl-C, SIGTERM) says how to continue; ``unit`` names what finished
    (``"trial"``, ``"reference seed"``, ...)."""
    single = HydraConfig.get().mode != RunMode.MULTIRUN
    try:
        action()
    except (RunInUseError, ForeignRunError) as error:  # not our directory: leave it alone
        log.error("%s", error)
        if single:
            sys.exit(2)
        raise
    except (Exception, KeyboardInterrupt) as error:
        record_failure(run_dir, error)
        if isinstance(error, KeyboardInterrupt):
            what = "terminated (SIGTERM)" if isinstance(error, Terminated) else "interrupted"
            log.error("%s; the finished %ss are kept: resume=%s", what, unit, run_dir)
            if single:  # the traceback is in failed.txt; the console gets the line alone
                sys.exit(143 if isinstance(error, Terminated) else 130)
        elif isinstance(error, EXPECTED_ERRORS):
            kind = "configuration error" if isinstance(error, ConfigError) else "run stopped"
            log.error("%s: %s", kind, error)
            if single:
                sys.exit(2 if isinstance(error, ConfigError) else 1)
        raise
