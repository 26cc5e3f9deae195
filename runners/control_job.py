"""GP feedback-linearisation torque control of a simulated arm (thesis chapter 5):
``python -m runners.control kernel=gip controller=gp_fl [+experiment=fl_initial_error]``.

The GP inverse-dynamics model is fitted once per (robot, kernel, data, gp settings) and
cached in ``model_dir`` (``models/<kernel>`` by default: data sets, ``gp.pt`` of tensors,
test nMSE, ``model.json`` naming what it was fitted to); the run directory holds one
tracking run per reference seed (``summary.csv``, ``tracking/seed_KK.npz``, ``rollouts.mcap``).
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
    SineReference,
    TorqueControlledRobot,
    TrackingController,
    TrackingRun,
    track,
)
from mcpilco.control.model_store import load_or_fit, new_model
from mcpilco.errors import RunFileError
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


def prepare(cfg: DictConfig) -> ControlSetup:
    """Check every key and build the robot and controller; no data, fit or tracking yet."""
    check_targets(cfg)
    robot: TorqueControlledRobot = make(cfg.robot)
    controller: TrackingController = make(cfg.controller)
    check_control_config(cfg, robot.num_joints, robot.dt)
    if cfg.get("threads") is not None:
        torch.set_num_threads(int(cfg.threads))
    if controller.needs_model:
        new_model(cfg, robot)  # the kernel and GP settings are checked here, before any data
    return ControlSetup(robot, controller)


def work(cfg: DictConfig, setup: ControlSetup, contract: RunContract, finished: list[Any]) -> None:
    """Get the model (fitted once per model directory), then track every reference seed
    not yet finished here; each seed's log chunk is closed before its summary row."""
    robot, controller, storage = setup.robot, setup.controller, contract.storage
    seeds = [int(s) for s in cfg.reference.seeds]
    done = [int(s) for s in finished]
    if done != seeds[: len(done)]:
        raise RunFileError(
            f"{storage.path / 'summary.csv'} lists reference seeds {done}, not a start of "
            f"reference.seeds={seeds}"
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
        for index, seed in enumerate(seeds):
            if seed in done:
                continue
            run, row = run_reference(cfg, robot, controller, storage, index, seed)
            log_run(observers, index, run, row)  # the log chunk first, the row last
            storage.append_summary(row, key=contract.kind.unit_key)
    finally:
        for observer in observers:
            observer.close()
    table = storage.summary()
    columns = [c for c in ("seed", "success", "diverged", "latency_p99_ms") if c in table.columns]
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
    seed: int,
) -> tuple[TrackingRun, dict[str, Any]]:
    """Track the reference of ``seed``; store its arrays; return its summary row."""
    reference_cfg = cfg.reference
    mean = reference_cfg.frequency_mean
    reference = SineReference.random(
        np.random.default_rng(seed),
        robot.num_joints,
        float(reference_cfg.amplitude),
        mean if isinstance(mean, int | float) else np.asarray(list(mean), dtype=np.float64),
        float(reference_cfg.frequency_std),
    )
    run = track(robot, controller, reference, reference_cfg.duration, reference_cfg.initial_error)
    metrics = run.metrics(reference_cfg.settle, reference_cfg.threshold_deg)
    arrays = {k: v for k, v in vars(run).items() if isinstance(v, np.ndarray)}
    storage.save_arrays(
        f"tracking/seed_{seed:02d}.npz", {**arrays, "frequencies": reference.frequencies}
    )
    row: dict[str, Any] = {"trial": index, "seed": seed}
    for key, value in metrics.items():
        if isinstance(value, list):
            row.update({f"{key}_{j + 1}": v for j, v in enumerate(value)})
        else:
            row[key] = value
    worst = max(metrics["steady_state_max_error_deg"])  # type: ignore[arg-type]
    log.info(
        "seed %d: %s, worst steady-state error %.3f deg, controller p99 %.3f ms",
        seed,
        "success" if metrics["success"] else ("diverged" if run.diverged else "no success"),
        worst,
        metrics["latency_p99_ms"],
    )
    return run, row


CONTROL_RUNNER: Runner[ControlSetup] = Runner(
    kind=CONTROL, resume_overrides=("threads",), prepare=prepare, work=work
)
