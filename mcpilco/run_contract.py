"""What a run directory is, and who may write into it: one contract for every runner.

A runner says what kind of run it makes and what its units are (:class:`RunKind`); the
contract decides what a rerun, a resume or another config means, the same way for all:

* ``run.json`` records the kind of run (``train``, ``control``, ``cgpdm``,
  ``cloth_datasets``); directories written before it existed are recognised by their
  ``config.yaml``. A directory of another kind is refused in one line and left untouched
  (no ``failed.txt``, no log), whatever the command.
* A directory that holds results is continued only by the same experiment: its saved
  config, minus the kind's machine keys (threads, device, ...), must equal the new one; the
  first key that differs is named otherwise. ``resume=DIR`` keeps the saved config;
  ``overwrite=true`` clears the directory first.
* Finished units (trials, reference seeds, test sequences, data sets) are the rows of
  ``summary.csv``, keyed by the kind's ``unit_key``: a rerun skips them and never adds a
  row twice (:meth:`mcpilco.run_storage.RunDirectory.append_summary`). A unit's log chunk is
  closed before its row is written (the row marks the unit finished).

The lock (:meth:`RunDirectory.locked`) is held throughout by the runner.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException
from yaml import YAMLError

from mcpilco.errors import ForeignRunError
from mcpilco.run_storage import RESUME_OVERRIDES, RunDirectory

log = logging.getLogger(__name__)

RUN_FILE = "run.json"
BOOKKEEPING = frozenset({"config.yaml", RUN_FILE, RunDirectory.LOCK_FILE, "failed.txt", ".hydra"})
"""Entries of a run directory that are not results (with ``*.log`` files)."""


@dataclass(frozen=True)
class RunKind:
    """What a runner makes.

    Attributes:
        name: recorded in ``run.json``.
        unit: what one row of ``summary.csv`` is, in words (``"trial"``), for messages.
        unit_key: the ``summary.csv`` column that keys finished units.
        machine_keys: dotted config keys that do not make another experiment.
        recognises: whether a ``config.yaml`` written before ``run.json`` existed (plain
            data) is one of this kind.
    """

    name: str
    unit: str
    unit_key: str
    machine_keys: tuple[str, ...]
    recognises: Callable[[Mapping[str, Any]], bool]


def recorded_kind(path: Path, kinds: Sequence[RunKind]) -> str | None:
    """The kind of run ``path`` holds: from ``run.json``, else recognised from the keys of
    its ``config.yaml`` (older directories); None for a directory holding neither."""
    run_file = path / RUN_FILE
    if run_file.is_file():
        try:
            recorded = json.loads(run_file.read_text())
            return str(recorded["kind"])
        except (OSError, ValueError, KeyError, TypeError):
            raise ForeignRunError(
                f"{run_file} is unreadable; not a run directory of mcpilco"
            ) from None
    config = saved_config(path)
    if config is None:
        return None
    for kind in kinds:
        if kind.recognises(config):
            return kind.name
    return "unknown"


def saved_config(path: Path) -> dict[str, Any] | None:
    """``path/config.yaml`` as plain data (nothing resolved or built); None when absent."""
    config_file = path / "config.yaml"
    if not config_file.is_file():
        return None
    try:
        loaded = OmegaConf.to_container(OmegaConf.load(config_file), resolve=False)
    except (OSError, UnicodeDecodeError, YAMLError, OmegaConfBaseException, ValueError):
        raise ForeignRunError(
            f"{config_file} is unreadable; not a run directory of mcpilco"
        ) from None
    if not isinstance(loaded, dict):
        raise ForeignRunError(f"{config_file} is not a config mapping")
    return loaded


def holds_results(path: Path) -> bool:
    """Whether ``path`` holds anything but bookkeeping (config, lock, logs, failure)."""
    if not path.is_dir():
        return False
    return any(entry.name not in BOOKKEEPING and entry.suffix != ".log" for entry in path.iterdir())


def without(config: Mapping[str, Any], dotted_keys: Sequence[str]) -> dict[str, Any]:
    """A deep copy of ``config`` without the ``dotted_keys`` (e.g. ``data.dir``)."""
    copy: dict[str, Any] = json.loads(json.dumps(config, default=str))
    for dotted in dotted_keys:
        node: Any = copy
        *parents, last = dotted.split(".")
        for name in parents:
            node = node.get(name) if isinstance(node, dict) else None
        if isinstance(node, dict):
            node.pop(last, None)
    return copy


def first_difference(saved: Any, current: Any, prefix: str = "") -> tuple[str, Any, Any] | None:
    """The first dotted key at which two plain configs differ, with both values; a key
    only ``current`` has, left at null (added to the config since), is no difference."""
    if isinstance(saved, dict) and isinstance(current, dict):
        for key in list(saved) + [k for k in current if k not in saved]:
            name = f"{prefix}.{key}" if prefix else str(key)
            if key not in saved:
                if current[key] is None:
                    continue
                return name, "<absent>", current[key]
            if key not in current:
                return name, saved[key], "<absent>"
            found = first_difference(saved[key], current[key], name)
            if found is not None:
                return found
        return None
    return None if saved == current else (prefix or "<config>", saved, current)


def _short(value: Any) -> str:
    if value == "<absent>":
        return "<absent>"
    text = json.dumps(value, default=str)
    return text if len(text) <= 60 else text[:57] + "..."


class RunContract:
    """The contract of one run directory for one runner (see the module docstring).

    Args:
        storage: the run directory (its lock held by the caller).
        kind: what the runner makes.
        kinds: every kind a directory may hold (to recognise older directories).
    """

    def __init__(self, storage: RunDirectory, kind: RunKind, kinds: Sequence[RunKind]) -> None:
        self.storage = storage
        self.kind = kind
        self.kinds = tuple(kinds)

    @property
    def path(self) -> Path:
        return self.storage.path

    def check_kind(self) -> None:
        """:class:`ForeignRunError` when the directory holds another kind of run."""
        found = recorded_kind(self.path, self.kinds)
        if found is not None and found != self.kind.name:
            raise ForeignRunError(
                f"{self.path} holds a {found} run, not a {self.kind.name} run; it is left as "
                "it is (pick another directory)"
            )

    def check_same_experiment(self, config: DictConfig, resume_hint: str) -> None:
        """:class:`ForeignRunError` naming the first differing key when the directory holds
        results of another experiment (machine keys aside)."""
        saved = saved_config(self.path)
        if saved is None or not holds_results(self.path):
            return
        current = OmegaConf.to_container(config, resolve=True)
        assert isinstance(current, dict)
        try:
            saved_resolved = OmegaConf.to_container(OmegaConf.create(saved), resolve=True)
        except OmegaConfBaseException:
            saved_resolved = saved
        ignored = (*self.kind.machine_keys, "resume", "overwrite")
        difference = first_difference(without(saved_resolved, ignored), without(current, ignored))
        if difference is not None:
            key, was, now = difference
            raise ForeignRunError(
                f"{self.path} holds a {self.kind.name} run made with {key}={_short(was)} (this "
                f"config: {_short(now)}); pick a new directory, pass overwrite=true to replace "
                f"it{resume_hint}"
            )

    def claim(
        self, config: DictConfig, *, overwrite: bool = False, resume_hint: str = ""
    ) -> list[Any]:
        """Take the directory for ``config``: refuse another kind or another experiment,
        clear it first with ``overwrite``, record the kind and the config, clear an old
        failure mark. Returns the finished units' keys (in ``summary.csv``'s order)."""
        self.check_kind()
        if overwrite:
            self.storage.clear()
            log.info("overwrite=true: cleared %s", self.path)
        else:
            self.check_same_experiment(config, resume_hint)
        self.storage.write_text(RUN_FILE, json.dumps({"kind": self.kind.name}) + "\n")
        self.storage.write_text("config.yaml", OmegaConf.to_yaml(config, resolve=True))
        self.storage.clear_failure()
        finished = self.storage.finished_units(self.kind.unit_key)
        if finished:
            log.info(
                "%s: %d %ss finished before; continuing", self.path, len(finished), self.kind.unit
            )
        return finished


TRAIN = RunKind(
    "train",
    unit="trial",
    unit_key="trial",
    machine_keys=(*RESUME_OVERRIDES, "tracking.rerun"),
    recognises=lambda config: "system" in config and "optimizer" in config,
)
CONTROL = RunKind(
    "control",
    unit="reference",
    unit_key="reference",
    machine_keys=("threads", "fit_model", "tracking.rerun"),
    recognises=lambda config: "robot" in config and "controller" in config,
)
CGPDM = RunKind(
    "cgpdm",
    unit="test sequence",
    unit_key="sequence",
    machine_keys=("threads", "device", "data.dir", "mode", "tracking.rerun"),
    recognises=lambda config: "cgpdm" in config and config.get("mode", "train") != "generate",
)
CLOTH_DATASETS = RunKind(
    "cloth_datasets",
    unit="data set",
    unit_key="range_deg",
    machine_keys=("threads", "device", "data.dir", "mode", "tracking.rerun"),
    recognises=lambda config: "cloth" in config and config.get("mode") == "generate",
)
KINDS = (TRAIN, CONTROL, CGPDM, CLOTH_DATASETS)
"""Every kind of run mcpilco's runners make."""

READERS = {
    "train": "analysis.summary, analysis.report, analysis.evaluate",
    "control": "analysis.control_report",
    "cgpdm": "analysis.cgpdm_report",
    "cloth_datasets": "runners.replay",
}
"""Which commands read each kind of run (for the one-line refusals of the others)."""


def find_runs(paths: Sequence[Path], kind: RunKind) -> list[Path]:
    """Every run directory of ``kind`` (one holding ``summary.csv``) under ``paths``;
    directories of another kind or with an unreadable record are left out with a one-line
    warning naming them and the commands that read them."""
    found = sorted({p.parent for path in paths for p in Path(path).rglob("summary.csv")})
    runs = []
    for run in found:
        try:
            recorded = recorded_kind(run, KINDS)
        except ForeignRunError as error:
            log.warning("%s; left out", error)
            continue
        if recorded not in (kind.name, None):
            readers = READERS.get(str(recorded), "no mcpilco command")
            log.warning("%s holds a %s run (read by %s); left out", run, recorded, readers)
            continue
        runs.append(run)
    return runs
