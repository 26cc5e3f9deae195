"""One Hydra job of any runner, under the run-directory contract (:mod:`mcpilco.run_contract`).

Every runner (``train``, ``control``, ``cgpdm``) says what it makes (a :class:`Runner`: its
kind of run, how to check and build its config without doing any work, and how to do the
work given the units already finished); this module does the rest, the same way for all:

1. ``resume=DIR``: the directory must hold a run of this kind (one line otherwise, and it
   is left untouched); its saved config is used, checked before anything in it is built,
   with only the runner's ``resume_overrides`` taken from the command line.
2. The directory's lock is taken (a second process is refused at once; in a sweep it
   waits, then finds the job done or continues it).
3. The kind is checked again, the config is checked and built (no work yet), then the
   directory is claimed: another experiment's results are refused naming the first key
   that differs, ``overwrite=true`` clears it, and the config is recorded.
4. The work runs with the finished units' keys, so nothing finished is done or listed
   twice. A failure, Ctrl-C or SIGTERM leaves ``failed.txt`` (:mod:`runners.failures`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Generic, TypeVar

from hydra.core.hydra_config import HydraConfig
from hydra.types import RunMode
from omegaconf import DictConfig

from mcpilco.errors import ForeignRunError
from mcpilco.run_contract import KINDS, RunContract, RunKind, recorded_kind
from mcpilco.run_storage import RunDirectory
from mcpilco.safe_config import load_run_config
from runners.failures import handle_signals, run_reporting_failures
from runners.process import also_log_to

log = logging.getLogger("mcpilco.runner")

Built = TypeVar("Built")


@dataclass(frozen=True)
class Runner(Generic[Built]):
    """What one runner contributes to a job.

    Attributes:
        kind: the kind of run it makes (its units, its machine keys).
        resume_overrides: top-level keys a resumed run takes from the command line (when
            given there) instead of its saved config.
        prepare: checks and builds everything from the config, before any work; raises
            :class:`ConfigError` (one line naming the key) on a bad value.
        work: does the work in the claimed directory, given what ``prepare`` built and the
            keys of the units already finished there.
    """

    kind: RunKind
    resume_overrides: tuple[str, ...]
    prepare: Callable[[DictConfig], Built]
    work: Callable[[DictConfig, Built, RunContract, list[Any]], None]


def given_on_command_line(key: str) -> bool:
    """Whether the command line sets the top-level ``key`` (``key=``, ``+key=``, ``++key=``)."""
    return any(
        override.lstrip("+").split("=", 1)[0] == key
        for override in HydraConfig.get().overrides.task
    )


def resolve_resume(cfg: DictConfig, kind: RunKind, overrides: tuple[str, ...]) -> DictConfig:
    """The config to run: ``cfg``, or with ``resume=DIR`` the saved config of that run
    (:class:`ForeignRunError`, one line, when it holds none or another kind of run:
    nothing is written there)."""
    if cfg.get("resume") is None:
        return cfg
    run_dir = Path(cfg.resume).expanduser().resolve()
    if not (run_dir / "config.yaml").is_file():
        raise ForeignRunError(f"resume={cfg.resume!r} holds no config.yaml (not a run directory)")
    found = recorded_kind(run_dir, KINDS)
    if found != kind.name:
        raise ForeignRunError(
            f"resume={str(cfg.resume)!r} holds a {found} run, not a {kind.name} run; it is "
            f"left as it is (runners.{_module_of(found)} continues it)"
        )
    saved = load_run_config(run_dir)
    for key in overrides:
        if given_on_command_line(key) or key not in saved:
            saved[key] = cfg.get(key)
    saved.resume = str(run_dir)
    return saved


def _module_of(kind_name: str | None) -> str:
    return {"cloth_datasets": "cgpdm mode=generate"}.get(str(kind_name), str(kind_name))


def job_directory(cfg: DictConfig) -> Path:
    """The directory a job writes into: ``resume``'s, else Hydra's output directory."""
    if cfg.get("resume"):
        return Path(cfg.resume).expanduser().resolve()
    return Path(HydraConfig.get().runtime.output_dir)


def run_job(cfg: DictConfig, runner: Runner[Any]) -> None:
    """Run one Hydra job of ``runner`` (see the module docstring)."""
    handle_signals()
    run_dir = job_directory(cfg)
    sweep = HydraConfig.get().mode == RunMode.MULTIRUN

    def job() -> None:
        config = resolve_resume(cfg, runner.kind, runner.resume_overrides)
        storage = RunDirectory(run_dir)
        with storage.locked(wait=sweep):
            contract = RunContract(storage, runner.kind, KINDS)
            contract.check_kind()
            if config.get("resume") is not None:  # the resumed units' log beside the others
                also_log_to(run_dir / f"{HydraConfig.get().job.name}.log")
            built = runner.prepare(config)
            hint = f", or continue it with resume={str(run_dir)!r}"
            overwrite = bool(config.get("overwrite")) and config.get("resume") is None
            finished = contract.claim(config, overwrite=overwrite, resume_hint=hint)
            log.info("run directory: %s", run_dir)
            runner.work(config, built, contract, finished)

    run_reporting_failures(job, run_dir, unit=runner.kind.unit)
