"""CGPDM of a cloth moved by two end-effectors (thesis chapter 6):
``python -m runners.cgpdm cgpdm=high data.range_deg=30 data.num_train=10 seed=0``.

One run trains one CGPDM on ``data.num_train`` sequences (draw ``seed``) of the data set of
range ``data.range_deg`` and predicts its test sequences. The data set is simulated once and
kept in ``data.dir`` (or read from ``data.path``, a file of ``mode=generate``, or from the
authors' CSV layout in ``data.csv_dir``). The run directory holds ``config.yaml``,
``summary.csv`` (one row per test sequence), ``model.pt`` (state dict), ``predictions.npz``,
``training_set.json`` and ``rollouts.mcap``; a run whose summary is complete is not redone,
one with ``model.pt`` only is evaluated without training again.

``mode=generate`` writes the data sets of ``data.ranges`` into the run directory
(``datasets/*.npz`` + ``.json``, every sequence in ``rollouts.mcap``) and checks the
simulation's stability over all of them.
"""

from __future__ import annotations

import json
import logging
from pathlib import Path
from typing import Any

import hydra
import numpy as np
import torch
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig, OmegaConf

from mcpilco.build import make, resolve_device
from mcpilco.cloth import ClothDataset, ClothParameters, ClothSimulation, Excitation
from mcpilco.cloth.dataset import read_csv_sequences
from mcpilco.cloth.store import DatasetKey, check_compatible, load_or_generate
from mcpilco.errors import ConfigError
from mcpilco.latent import CGPDM
from mcpilco.latent.evaluation import point_distance_per_step
from mcpilco.latent.study import check_sizes, evaluate, score, split, train, training_data
from mcpilco.latent.training import CGPDMTraining
from mcpilco.run_storage import RunDirectory, load_tensors
from mcpilco.safe_config import check_targets
from mcpilco.tracking import McapLogger
from mcpilco.tracking.metadata import run_metadata
from runners.cloth_data import excitation_from, generate_datasets, sequence_trajectory
from runners.failures import run_reporting_failures
from runners.options import rerun_mode

CONFIG_DIR = str(Path(__file__).resolve().parent.parent / "conf")
log = logging.getLogger("mcpilco.cgpdm")


def load_dataset(cfg: DictConfig, cloth: ClothParameters, excitation: Excitation) -> ClothDataset:
    """The data set the config names (``data.csv_dir``, ``data.path`` or the cache)."""
    data = cfg.data
    if data.csv_dir:
        return read_csv_sequences(
            Path(data.csv_dir), duplicate_controls=data.csv_duplicate_controls
        )
    if data.path:
        dataset = ClothDataset.load(Path(data.path))
        check_compatible(dataset, cloth, excitation, data.range_deg, str(data.path))
        return dataset
    key = DatasetKey(cloth, excitation, float(data.range_deg), int(data.seed),
                     int(data.num_sequences))  # fmt: skip
    dataset, _ = load_or_generate(Path(data.dir), key)
    return dataset


def train_and_evaluate(cfg: DictConfig) -> None:
    """Build and check everything first, then data, training (or the saved model), test."""
    check_targets(cfg)
    if cfg.get("threads") is not None:
        torch.set_num_threads(int(cfg.threads))
    cloth: ClothParameters = make(cfg.cloth)
    excitation = excitation_from(cfg)
    model: CGPDM = make(cfg.cgpdm)
    rerun_mode(cfg)
    device = resolve_device(str(cfg.device))
    fit = CGPDMTraining(**OmegaConf.to_container(cfg.train))  # type: ignore[arg-type]
    if cfg.data.csv_dir is None and not 0 < float(cfg.data.range_deg) <= 360:
        raise ConfigError(f"data.range_deg={cfg.data.range_deg!r} must be in (0, 360]")
    if cfg.data.csv_dir is None and cfg.data.path is None:  # checked before simulating
        check_sizes(cfg.data.num_sequences, cfg.data.num_test, cfg.data.num_train)
        model.check_observation_dim(ClothSimulation.observation_dim)
    run_dir = Path(HydraConfig.get().runtime.output_dir)
    storage = RunDirectory(run_dir)
    with storage.locked():
        summary = run_dir / "summary.csv"
        if summary.exists() and len(storage.summary()) == cfg.data.num_test:
            log.info("%s is complete; nothing to do", run_dir)
            return
        dataset = load_dataset(cfg, cloth, excitation)
        train_rows, test_rows = split(dataset, cfg.data.num_test, cfg.data.num_train, cfg.seed)
        model.check_observation_dim(dataset.observations.shape[-1])
        training, test = dataset.subset(train_rows), dataset.subset(test_rows)
        config_yaml = OmegaConf.to_yaml(cfg, resolve=True)
        storage.write_text("config.yaml", config_yaml)
        storage.clear_failure()
        summary.unlink(missing_ok=True)
        storage.write_text(
            "training_set.json",
            json.dumps(
                {
                    "draw": cfg.seed,
                    "train": training.indices.tolist(),
                    "test": test.indices.tolist(),
                }
            ),
        )
        saved = run_dir / "model.pt"
        model.set_data(training_data(training, device))
        if saved.exists():
            model.load_state_dict(load_tensors(saved))
            loss, seconds = float(model.negative_log_marginal_likelihood().detach()), float("nan")
            log.info("loaded the trained model from %s", saved)
        else:
            trace, seconds = train(model, fit)
            loss = trace[-1]
            storage.save_tensors("model.pt", model.state_dict())
            storage.write_text(
                "training_trace.csv",
                "step,loss\n" + "".join(f"{k + 1},{value!r}\n" for k, value in enumerate(trace)),
            )
        log.info(
            "trained on %d sequences (%d points) in %.1f s, loss %.4f",
            len(train_rows),
            training.observations.shape[0] * training.observations.shape[1],
            seconds,
            loss,
        )
        latent, predicted, predict_seconds = evaluate(model, test)
        errors = score(test, predicted)
        storage.save_arrays(
            "predictions.npz",
            {
                "latent": latent,
                "predicted": predicted,
                "true": test.observations,
                "controls": test.controls,
                "training_latent": model.sequences().detach().cpu().numpy(),
            },
        )
        log_test_sequences(
            cfg,
            run_dir,
            config_yaml,
            test,
            latent,
            predicted,
            errors,
            seconds,
            predict_seconds,
            loss,
            storage,
        )
    table = storage.summary()
    log.info(
        "R=%s n=%d draw=%d %s: mean error %.4f m (still %.4f, rigid %.4f)",
        cfg.data.range_deg,
        cfg.data.num_train,
        cfg.seed,
        cfg.cgpdm_name,
        table.error_m.mean(),
        table.still_error_m.mean(),
        table.rigid_error_m.mean(),
    )


def tracking_observers(cfg: DictConfig, run_dir: Path) -> list[Any]:
    """The MCAP logger and, with ``tracking.rerun=save``, the mesh recording."""
    observers: list[Any] = [McapLogger(run_dir)] if cfg.tracking.mcap else []
    if rerun_mode(cfg) == "save":
        from mcpilco.tracking.mesh_stream import MeshRerunStreamer

        observers.append(MeshRerunStreamer(run_dir))
    return observers


def log_test_sequences(
    cfg: DictConfig,
    run_dir: Path,
    config_yaml: str,
    test: ClothDataset,
    latent: np.ndarray,
    predicted: np.ndarray,
    errors: dict[str, np.ndarray],
    train_seconds: float,
    predict_seconds: float,
    loss: float,
    storage: RunDirectory,
) -> None:
    """Per test sequence, to the MCAP log (and the Rerun recording): the true cloth (state)
    with the prediction (measurement), the latent trajectory, and its summary row (also
    appended to ``summary.csv``)."""
    observers = tracking_observers(cfg, run_dir)
    for observer in observers:
        observer.run_started(run_metadata(config_yaml, cfg.seed, "cpu", "float64"), -1)
    dt = float(cfg.cloth.sample_dt)
    distances = point_distance_per_step(test.observations, predicted)  # [S, N] m
    try:
        for k in range(len(test.indices)):
            distance = distances[k]
            row = {
                "trial": k,
                "sequence": int(test.indices[k]),
                "range_deg": cfg.data.range_deg,
                "num_train": cfg.data.num_train,
                "draw": cfg.seed,
                "variant": cfg.cgpdm_name,
                "error_m": float(errors["model"][k]),
                "still_error_m": float(errors["still"][k]),
                "rigid_error_m": float(errors["rigid"][k]),
                "eval_cost": float(errors["model"][k]),
                "fit_seconds": train_seconds,
                "predict_seconds": predict_seconds,
                "final_loss": loss,
            }
            for observer in observers:
                observer.rollout(
                    k,
                    sequence_trajectory(test.observations[k], test.controls[k], dt, predicted[k]),
                    distance,
                    distance,
                    kind="cloth",
                )
                observer.rollout(
                    k,
                    sequence_trajectory(latent[k], test.controls[k], dt),
                    distance,
                    distance,
                    kind="latent",
                )
            storage.append_summary(row)
            for observer in observers:
                observer.trial_finished(k, row)
    finally:
        for observer in observers:
            observer.close()


@hydra.main(version_base="1.3", config_path=CONFIG_DIR, config_name="cgpdm")
def main(cfg: DictConfig) -> None:
    """Hydra entry point; failures as in ``runners.train`` (one line, ``failed.txt``)."""
    run_dir = Path(HydraConfig.get().runtime.output_dir)
    if cfg.mode not in ("train", "generate"):
        raise ConfigError(f"mode={cfg.mode!r} must be train or generate")
    action = train_and_evaluate if cfg.mode == "train" else generate_datasets
    run_reporting_failures(lambda: action(cfg), run_dir, resume_hint=False)


if __name__ == "__main__":
    main()
