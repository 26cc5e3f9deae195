"""GP feedback-linearisation torque control of a simulated arm (thesis chapter 5):
``python -m runners.control kernel=gip controller=gp_fl [+experiment=fl_initial_error]``.

The GP inverse-dynamics model is fitted once per (robot, kernel, data, gp settings) and
cached in ``model_dir`` (``models/<kernel>`` by default: data sets, ``gp.pt`` of tensors,
test nMSE, ``model.json`` naming what it was fitted to); the run directory holds one
tracking run per reference seed (``summary.csv``, ``tracking/seed_KK.npz``, ``rollouts.mcap``).
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import hydra
import numpy as np
import torch
from hydra.core.hydra_config import HydraConfig
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
from mcpilco.control.model_store import load_or_fit
from mcpilco.errors import ConfigError
from mcpilco.run_storage import RunDirectory
from mcpilco.safe_config import check_targets
from mcpilco.tracking import McapLogger
from mcpilco.tracking.metadata import run_metadata
from mcpilco.trajectory import Trajectory
from runners.failures import run_reporting_failures
from runners.options import rerun_mode

CONFIG_DIR = str(Path(__file__).resolve().parent.parent / "conf")
log = logging.getLogger("mcpilco.control")


def check_reference(reference: DictConfig) -> None:
    """One-line errors naming the ``reference.*`` key, before any work."""
    seeds = reference.seeds
    if not seeds or not all(isinstance(s, int) and s >= 0 for s in seeds):
        raise ConfigError(f"reference.seeds={list(seeds)!r} must be non-negative integers")
    for key in ("duration", "threshold_deg"):
        value = reference[key]
        if not isinstance(value, int | float) or not np.isfinite(value) or value <= 0:
            raise ConfigError(f"reference.{key}={value!r} must be positive")
    for key in ("settle", "initial_error", "amplitude", "frequency_std"):
        value = reference[key]
        if not isinstance(value, int | float) or not np.isfinite(value):
            raise ConfigError(f"reference.{key}={value!r} must be a finite number")
    if not 0 <= reference.settle < reference.duration:
        raise ConfigError(f"reference.settle={reference.settle} must be in [0, duration)")


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


def control(cfg: DictConfig) -> None:
    """Build and check everything, get the model, run the tracking experiments."""
    check_targets(cfg)
    if cfg.get("threads") is not None:
        torch.set_num_threads(int(cfg.threads))
    robot: TorqueControlledRobot = make(cfg.robot)
    controller: TrackingController = make(cfg.controller)
    check_reference(cfg.reference)
    rerun_mode(cfg)
    run_dir = Path(HydraConfig.get().runtime.output_dir)
    storage = RunDirectory(run_dir)
    with storage.locked():
        model: GPInverseDynamics | None = None
        if controller.needs_model:
            model = load_or_fit(cfg, robot, Path(cfg.model_dir))
        controller.bind(robot, model)
        config_yaml = OmegaConf.to_yaml(cfg, resolve=True)
        storage.write_text("config.yaml", config_yaml)
        storage.clear_failure()
        observers = tracking_observers(cfg, run_dir)
        for observer in observers:
            observer.run_started(run_metadata(config_yaml, cfg.seed, "cpu", "float64"), -1)
        try:
            for index, seed in enumerate(cfg.reference.seeds):
                run, row = run_reference(cfg, robot, controller, storage, index, seed)
                log_run(observers, index, run, row)
        finally:
            for observer in observers:
                observer.close()
    log.info("summary:\n%s", storage.summary().to_string(index=False))


def run_reference(
    cfg: DictConfig,
    robot: TorqueControlledRobot,
    controller: TrackingController,
    storage: RunDirectory,
    index: int,
    seed: int,
) -> tuple[TrackingRun, dict[str, Any]]:
    """Track the reference of ``seed``; store its arrays and summary row."""
    reference_cfg = cfg.reference
    reference = SineReference.random(
        np.random.default_rng(seed),
        robot.num_joints,
        reference_cfg.amplitude,
        reference_cfg.frequency_mean,
        reference_cfg.frequency_std,
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
    storage.append_summary(row)
    worst = max(metrics["steady_state_max_error_deg"])  # type: ignore[arg-type]
    log.info(
        "seed %d: %s, worst steady-state error %.3f deg, controller p99 %.3f ms",
        seed,
        "success" if metrics["success"] else ("diverged" if run.diverged else "no success"),
        worst,
        metrics["latency_p99_ms"],
    )
    return run, row


@hydra.main(version_base="1.3", config_path=CONFIG_DIR, config_name="control")
def main(cfg: DictConfig) -> None:
    """Hydra entry point; failures as in ``runners.train`` (one line, ``failed.txt``)."""
    run_dir = Path(HydraConfig.get().runtime.output_dir)
    run_reporting_failures(lambda: control(cfg), run_dir, resume_hint=False)


if __name__ == "__main__":
    main()
