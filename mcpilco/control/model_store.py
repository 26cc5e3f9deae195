"""A fitted inverse-dynamics GP on disk: fitted once, reused by every controller run.

Layout of a model directory::

    model.json          what the model was fitted to (robot, kernel, data, gp settings),
                        the fit's cost and the test nMSE per joint; written last
    gp.pt               tensors only (hyper-parameters, data, α, scales)
    data/train.npz, data/test.npz      the data sets (q, q̇, q̈, τ, dt)
    test_predictions.npz               f̂ and τ on the test set
    rollouts.mcap       the data sets as rollouts (trial 0: train, 1: test)
"""

from __future__ import annotations

import json
import logging
from pathlib import Path
from typing import Any

import numpy as np
import torch
from omegaconf import DictConfig, OmegaConf

from mcpilco.build import make
from mcpilco.control.data import InverseDynamicsData, collect
from mcpilco.control.inverse_dynamics import GPInverseDynamics, nmse_percent
from mcpilco.control.robot import TorqueControlledRobot
from mcpilco.errors import CheckpointError, ConfigError
from mcpilco.run_storage import RunDirectory, load_tensors
from mcpilco.trajectory import Trajectory

log = logging.getLogger(__name__)


def identity(cfg: DictConfig, robot: TorqueControlledRobot) -> dict[str, Any]:
    """What makes two fitted models the same: robot, kernel, data and GP settings."""
    return {
        "robot": robot.name,
        "kernel": OmegaConf.to_container(cfg.kernel, resolve=True),
        "data": OmegaConf.to_container(cfg.data, resolve=True),
        "gp": OmegaConf.to_container(cfg.gp, resolve=True),
    }


def new_model(cfg: DictConfig, robot: TorqueControlledRobot) -> GPInverseDynamics:
    return GPInverseDynamics(
        make(cfg.kernel),
        robot.num_joints,
        noise_std=cfg.gp.noise_std,
        fit_points=cfg.gp.fit_points,
        max_iterations=cfg.gp.max_iterations,
    )


def load_or_fit(
    cfg: DictConfig, robot: TorqueControlledRobot, model_dir: Path
) -> GPInverseDynamics:
    """The model in ``model_dir`` if it was fitted to this robot, kernel, data and GP
    settings (one-line error if it was fitted to anything else); fitted here and saved when
    the directory holds none and ``fit_model`` is true (one-line error otherwise). Processes
    sharing the directory wait for each other (the first fits, the others load)."""
    wanted = identity(cfg, robot)
    storage = RunDirectory(model_dir)
    with storage.locked(wait=True):
        meta_path = model_dir / "model.json"
        if meta_path.is_file():
            try:
                saved = json.loads(meta_path.read_text())
            except (json.JSONDecodeError, UnicodeDecodeError) as error:
                raise ConfigError(
                    f"model_dir={str(model_dir)!r}: model.json unreadable ({error})"
                ) from None
            if not isinstance(saved, dict):
                raise ConfigError(
                    f"model_dir={str(model_dir)!r}: model.json holds a "
                    f"{type(saved).__name__}, not a model's record; pick another model_dir"
                )
            for key in ("robot", "kernel", "data", "gp"):
                if saved.get(key) != wanted[key]:
                    raise ConfigError(
                        f"model_dir={str(model_dir)!r} holds a model fitted with a different "
                        f"{key} ({_short(saved.get(key))} vs {_short(wanted[key])}); pick another "
                        "model_dir"
                    )
            model = new_model(cfg, robot)
            try:
                model.load_state_dict(load_tensors(model_dir / "gp.pt"))
            except (RuntimeError, KeyError, ValueError) as error:
                first = str(error).strip().splitlines()[0] if str(error).strip() else ""
                raise CheckpointError(
                    f"{model_dir / 'gp.pt'} does not fit the model model.json names "
                    f"({type(error).__name__}: {first[:120]})"
                ) from None
            log.info(
                "loaded the GP model in %s (test nMSE %% %s)", model_dir, saved.get("nmse_percent")
            )
            return model
        if not cfg.fit_model:
            raise ConfigError(
                f"model_dir={str(model_dir)!r} holds no fitted model and fit_model=false"
            )
        return fit_and_save(cfg, robot, storage, wanted)


def _short(value: Any) -> str:
    text = json.dumps(value, sort_keys=True)
    return text if len(text) <= 80 else text[:77] + "..."


def fit_and_save(
    cfg: DictConfig, robot: TorqueControlledRobot, storage: RunDirectory, wanted: dict[str, Any]
) -> GPInverseDynamics:
    """Collect train and test data, fit, evaluate on the test set, save (model.json last)."""
    data_cfg = cfg.data
    settings = {
        key: data_cfg[key]
        for key in (
            "duration",
            "downsample",
            "cutoff_hz",
            "reference_std",
            "kp",
            "kd",
            "torque_limit",
        )
    }
    sets = {}
    for name in ("train", "test"):
        log.info(
            "collecting the %s data: %.0f s of PD tracking on the simulated robot",
            name,
            data_cfg.duration,
        )
        rng = np.random.default_rng(data_cfg[f"{name}_seed"])
        sets[name] = collect(robot, rng, **settings)
        storage.save_arrays(f"data/{name}.npz", sets[name].as_arrays())
    log.info(
        "fitting the GP inverse dynamics on %d samples: hyperparameters by ML-II, then the "
        "posterior (minutes on 2 cores at the default sizes)",
        len(sets["train"].inputs),
    )
    model = new_model(cfg, robot)
    report = model.fit(sets["train"], torch.Generator().manual_seed(int(cfg.seed)))
    test: InverseDynamicsData = sets["test"]
    inputs = torch.as_tensor(test.inputs, dtype=torch.float64)
    predicted = torch.cat([model.torques(inputs[i : i + 500]) for i in range(0, len(inputs), 500)])
    nmse = nmse_percent(predicted.numpy(), test.torques)
    storage.save_arrays(
        "test_predictions.npz", {"predicted": predicted.numpy(), "measured": test.torques}
    )
    storage.save_tensors("gp.pt", model.state_dict())
    _log_data_sets(storage.path, sets)
    meta = {**wanted, "fit": vars(report), "nmse_percent": nmse.round(4).tolist()}
    storage.write_text("model.json", json.dumps(meta, indent=2))
    log.info(
        "fitted the GP model in %s: ML-II on %d points %.0f s, posterior on %d %.0f s; "
        "test nMSE %% per joint %s",
        storage.path,
        report.fit_points,
        report.hyperparameter_seconds,
        report.posterior_points,
        report.posterior_seconds,
        np.round(nmse, 2).tolist(),
    )
    return model


def _log_data_sets(model_dir: Path, sets: dict[str, InverseDynamicsData]) -> None:
    """The data sets in the model directory's MCAP log (trial 0 train, 1 test): state
    [q, q̇], reading q̈, action τ (the last sample's τ is in the npz only)."""
    from mcpilco.tracking import McapLogger

    logger = McapLogger(model_dir)
    logger.run_started({"config": "{}"}, -1)
    for trial, (name, data) in enumerate(sets.items()):
        trajectory = Trajectory(
            states=np.concatenate([data.positions, data.velocities], axis=1),
            measurements=data.accelerations,
            actions=data.torques[:-1],
            dt=data.dt,
        )
        zeros = np.zeros(len(data.positions))
        logger.rollout(trial, trajectory, zeros, zeros, kind=name)
        logger.trial_finished(trial, {})
    logger.close()
