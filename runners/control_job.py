"""GP feedback-linearisation torque control of a simulated arm (thesis chapter 5):
``python -m runners.control kernel=gip controller=gp_fl [+experiment=fl_initial_error]``.

The GP inverse-dynamics model is fitted once per (robot, kernel, data, gp settings) and
cached in ``model_dir`` (``models/<kernel>`` by default: data sets, ``gp.pt`` of tensors,
test nMSE, ``model.json`` naming what it was fitted to); the run directory holds one
tracking run per reference of the ``reference`` group (``summary.csv`` keyed by the
reference's label, ``tracking/<label>.npz``, ``rollouts.mcap``).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from omegaconf import DictConfig, OmegaConf

from mcpilco.build import make
from mcpilco.control import (
    GPInverseDynamics,
    Reference,
    ReferenceFamily,
    TorqueControlledRobot,
    TrackingController,
    TrackingRun,
    track,
)
from mcpilco.control.model_store import load_or_fit, new_model
from mcpilco.errors import ConfigError, RunFileError
from mcpilco.run_contract import CONTROL, RunContract
from mcpilco.run_storage import RunDirectory
from mcpilco.safe_config import check_targets
from mcpilco.tracking import McapLogger
from mcpilco.tracking.metadata import run_metadata
from mcpilco.trajectory import Trajectory
from runners.control_checks import check_control_config
from runners.job import Runner
from runners.options import rerun_mode

log = logging.getLogger("mcpilco.control")


def tracking_observers(cfg: DictConfig, run_dir: Path) -> list[Any]:
    """The MCAP logger and, with ``tracking.rerun=save``, the Rerun recording."""
    observers: list[Any] = []
    if cfg.tracking.mcap:
        observers.append(McapLogger(run_dir))
    if rerun_mode(cfg) == "save":
        from mcpilco.tracking import RerunStreamer

        observers.append(RerunStreamer(run_dir, mode="save"))
    return observers


def log_run(observers: list[Any], index: int, run: TrackingRun, row: dict[str, Any]) -> None:
    """One tracking run as a rollout: state [q, q̇], reading r, action τ, cost ‖e‖ (rad),
    evaluation cost max_j |e_j| (deg)."""
    trajectory = Trajectory(
        states=np.concatenate([run.positions, run.velocities], axis=1),
        measurements=run.reference,
        actions=run.torques,
        dt=float(run.time[1] - run.time[0]),
    )
    costs = np.linalg.norm(run.errors, axis=1)
    worst = np.degrees(np.abs(run.errors).max(axis=1))
    for observer in observers:
        observer.rollout(index, trajectory, costs, worst, kind="tracking")
        observer.trial_finished(index, row)


@dataclass
class ControlSetup:
    """What a control run is built from (checked, before any work)."""

    robot: TorqueControlledRobot
    controller: TrackingController
    references: list[Reference]


def prepare(cfg: DictConfig) -> ControlSetup:
    """Check every key and build the robot, controller and references (a reference file
    is read and checked here); no data, fit or tracking yet."""
    check_targets(cfg)
    robot: TorqueControlledRobot = make(cfg.robot)
    controller: TrackingController = make(cfg.controller)
    family: ReferenceFamily = make(cfg.reference)
    references = family.references(robot.num_joints)
    labels = [r.label for r in references]
    if not references or len(set(labels)) != len(labels):
        raise ConfigError(f"reference: the references' labels {labels} must be distinct, not none")
    check_control_config(cfg, robot.num_joints, robot.dt, [r.duration for r in references])
    limits = robot.torque_limits
    log.info(
        "robot %s: torque limits %s%s",
        robot.name,
        "off (robot.torque_limit=null)"
        if limits is None
        else f"{np.round(limits, 3).tolist()} N m",
        f"; held joints {held}" if (held := getattr(robot, "held_joints", [])) else "",
    )
    if cfg.get("threads") is not None:
        torch.set_num_threads(int(cfg.threads))
    if controller.needs_model:
        new_model(cfg, robot)  # the kernel and GP settings are checked here, before any data
    return ControlSetup(robot, controller, references)


def work(cfg: DictConfig, setup: ControlSetup, contract: RunContract, finished: list[Any]) -> None:
    """Get the model (fitted once per model directory), then track every reference not
    yet finished here; each reference's log chunk is closed before its summary row."""
    robot, controller, storage = setup.robot, setup.controller, contract.storage
    labels = [r.label for r in setup.references]
    done = [str(s) for s in finished]
    if done != labels[: len(done)]:
        raise RunFileError(
            f"{storage.path / 'summary.csv'} lists references {done}, not a start of this "
            f"run's {labels}"
        )
    model: GPInverseDynamics | None = None
    if controller.needs_model:
        model = load_or_fit(cfg, robot, Path(cfg.model_dir))
    controller.bind(robot, model)
    config_yaml = OmegaConf.to_yaml(cfg, resolve=True)
    observers = tracking_observers(cfg, storage.path)
    for observer in observers:
        observer.run_started(run_metadata(config_yaml, cfg.seed, "cpu", "float64"), len(done) - 1)
    try:
        for index, reference in enumerate(setup.references):
            if reference.label in done:
                continue
            run, row = run_reference(cfg, robot, controller, storage, index, reference)
            log_run(observers, index, run, row)  # the log chunk first, the row last
            storage.append_summary(row, key=contract.kind.unit_key)
    finally:
        for observer in observers:
            observer.close()
    table = storage.summary()
    columns = [
        c
        for c in ("reference", "success", "diverged", "saturated_share", "latency_p99_ms")
        if c in table.columns
    ]
    log.info(
        "summary (every column: %s):\n%s",
        storage.path / "summary.csv",
        table[columns].to_string(index=False, float_format=lambda v: f"{v:.4g}"),
    )


def run_reference(
    cfg: DictConfig,
    robot: TorqueControlledRobot,
    controller: TrackingController,
    storage: RunDirectory,
    index: int,
    reference: Reference,
) -> tuple[TrackingRun, dict[str, Any]]:
    """Track ``reference``; store its arrays; return its summary row."""
    task = cfg.task
    run = track(robot, controller, reference, initial_error=task.initial_error)
    metrics = run.metrics(task.settle, task.threshold_deg)
    arrays = {k: v for k, v in vars(run).items() if isinstance(v, np.ndarray)}
    storage.save_arrays(f"tracking/{reference.label}.npz", {**arrays, **reference.parameters()})
    row: dict[str, Any] = {"trial": index, "reference": reference.label}
    if reference.label.startswith("seed_"):
        row["seed"] = int(reference.label.removeprefix("seed_"))
    for key, value in metrics.items():
        if isinstance(value, list):
            row.update({f"{key}_{j + 1}": v for j, v in enumerate(value)})
        else:
            row[key] = value
    worst = max(metrics["steady_state_max_error_deg"])  # type: ignore[arg-type]
    log.info(
        "reference %s: %s, worst steady-state error %.3f deg, torque limits cut %.1f %% of "
        "steps, controller p99 %.3f ms",
        reference.label,
        "success" if metrics["success"] else ("diverged" if run.diverged else "no success"),
        worst,
        100 * float(metrics["saturated_share"]),  # type: ignore[arg-type]
        metrics["latency_p99_ms"],
    )
    return run, row


CONTROL_RUNNER: Runner[ControlSetup] = Runner(
    kind=CONTROL, resume_overrides=("threads",), prepare=prepare, work=work
)
