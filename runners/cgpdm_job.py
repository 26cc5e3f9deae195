"""CGPDM of a cloth moved by two end-effectors (thesis chapter 6):
``python -m runners.cgpdm cgpdm=high data.range_deg=30 data.num_train=10 seed=0``.

One run trains one CGPDM on ``data.num_train`` sequences (draw ``seed``) of the data set of
range ``data.range_deg`` and predicts its test sequences. The data set is simulated once and
kept in ``data.dir`` (or read from ``data.path``, a file of ``mode=generate``, or from the
authors' CSV layout in ``data.csv_dir``). The run directory holds ``config.yaml``,
``summary.csv`` (one row per test sequence), ``model.pt`` (state dict), ``predictions.npz``,
``training.json``, ``training_set.json`` and ``rollouts.mcap``. The run-directory contract
(:mod:`mcpilco.run_contract`) holds: a rerun of the same config skips the test sequences in
the summary (and training, once ``model.pt`` is there); another config is refused.

``mode=generate`` writes the data sets of ``data.ranges`` into the run directory
(``datasets/*.npz`` + ``.json``, every sequence in ``rollouts.mcap``) and checks the
simulation's stability over all of them (:mod:`runners.cloth_data`).
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from omegaconf import DictConfig, OmegaConf

from mcpilco.build import make, resolve_device
from mcpilco.cloth import ClothDataset, ClothParameters, ClothSimulation, Excitation
from mcpilco.cloth.dataset import read_csv_sequences
from mcpilco.cloth.store import DatasetKey, check_compatible, load_or_generate
from mcpilco.errors import RunFileError
from mcpilco.latent import CGPDM
from mcpilco.latent.evaluation import point_distance_per_step
from mcpilco.latent.study import evaluate, score, train, training_data
from mcpilco.latent.training import CGPDMTraining
from mcpilco.run_contract import CGPDM as CGPDM_KIND
from mcpilco.run_contract import CLOTH_DATASETS, RunContract
from mcpilco.run_storage import RunDirectory, load_tensors
from mcpilco.safe_config import check_targets
from mcpilco.tracking import McapLogger
from mcpilco.tracking.metadata import run_metadata
from runners.cgpdm_checks import check_cgpdm_config, check_training_size, error_units, split_rule
from runners.cloth_data import (
    excitation_from,
    generate_datasets,
    prepare_generation,
    sequence_trajectory,
)
from runners.job import Runner
from runners.options import rerun_mode

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


@dataclass
class CGPDMSetup:
    """What a CGPDM run is built from (checked, before any simulation or training)."""

    cloth: ClothParameters
    excitation: Excitation
    model: CGPDM
    fit: CGPDMTraining
    device: torch.device


def prepare(cfg: DictConfig) -> CGPDMSetup:
    """Check every key and build the cloth, excitation, model and training schedule."""
    check_targets(cfg)
    check_cgpdm_config(cfg)
    if cfg.get("threads") is not None:
        torch.set_num_threads(int(cfg.threads))
    cloth: ClothParameters = make(cfg.cloth)
    excitation = excitation_from(cfg)
    model: CGPDM = make(cfg.cgpdm)
    model.check_kernels(control_dim=6)
    rerun_mode(cfg)
    device = resolve_device(str(cfg.device))
    fit = CGPDMTraining(**OmegaConf.to_container(cfg.train))  # type: ignore[arg-type]
    if cfg.data.csv_dir is None and cfg.data.path is None:  # checked before simulating
        model.check_observation_dim(ClothSimulation.observation_dim)
    check_training_size(cfg)
    return CGPDMSetup(cloth, excitation, model, fit, device)


def train_model(setup: CGPDMSetup, storage: RunDirectory) -> tuple[float, float]:
    """Train the model whose data are set, or load the one trained here before (a run
    killed after training). The model's record is ``training_trace.csv``,
    ``training.json`` (seconds, loss) and ``model.pt``, written in that order: ``model.pt``
    marks it complete. Returns (training seconds, final loss)."""
    model, saved = setup.model, storage.path / "model.pt"
    if saved.exists():
        model.load_state_dict(load_tensors(saved))
        loss = float(model.negative_log_marginal_likelihood().detach())
        record = storage.path / "training.json"
        seconds = json.loads(record.read_text())["seconds"] if record.is_file() else float("nan")
        log.info("loaded the model trained here before (%s)", saved)
        return float(seconds), loss
    trace, seconds = train(setup.model, setup.fit)
    storage.write_text(
        "training_trace.csv",
        "step,loss\n" + "".join(f"{k + 1},{value!r}\n" for k, value in enumerate(trace)),
    )
    storage.write_text("training.json", json.dumps({"seconds": seconds, "loss": trace[-1]}))
    storage.save_tensors("model.pt", model.state_dict())
    return seconds, trace[-1]


def work(cfg: DictConfig, setup: CGPDMSetup, contract: RunContract, finished: list[Any]) -> None:
    """Data, training (or the model trained here before), then every test sequence not
    yet in the summary: its log chunk, then its row."""
    storage = contract.storage
    rule = split_rule(cfg)
    if len(finished) == rule.counts[1]:
        log.info("%s is complete; nothing to do", storage.path)
        return
    dataset = load_dataset(cfg, setup.cloth, setup.excitation)
    train_rows, test_rows = rule.rows(dataset)
    setup.model.check_observation_dim(dataset.observations.shape[-1])
    training, test = dataset.subset(train_rows), dataset.subset(test_rows)
    range_note = (
        "a label from the config (CSV data: the movement range is not known)"
        if cfg.data.csv_dir
        else "the movement range R of the simulated data set"
    )
    record = {
        **rule.record(dataset, train_rows, test_rows),
        "units": error_units(cfg),
        "range_deg": {"value": cfg.data.range_deg, "meaning": range_note},
    }
    storage.write_text("training_set.json", json.dumps(record))
    setup.model.set_data(training_data(training, setup.device))
    log.info(
        "training the %s CGPDM on %d sequences (R=%s, draw %d): %d outer L-BFGS steps",
        cfg.cgpdm_name,
        len(train_rows),
        cfg.data.range_deg,
        cfg.seed,
        cfg.train.steps,
    )
    seconds, loss = train_model(setup, storage)
    log.info(
        "trained on %d sequences (%d points) in %.1f s, loss %.4f",
        len(train_rows),
        training.observations.shape[0] * training.observations.shape[1],
        seconds,
        loss,
    )
    latent, predicted, predict_seconds = evaluate(setup.model, test)
    errors = score(test, predicted)
    storage.save_arrays(
        "predictions.npz",
        {
            "latent": latent,
            "predicted": predicted,
            "true": test.observations,
            "controls": test.controls,
            "training_latent": setup.model.sequences().detach().cpu().numpy(),
        },
    )
    results = TestResults(
        test, latent, predicted, errors, seconds, predict_seconds, loss, training.indices.tolist()
    )
    log_test_sequences(cfg, contract, results, [int(s) for s in finished])
    table, units = storage.summary(), error_units(cfg)
    log.info(
        "R=%s n=%d draw=%d %s: mean error %.4f %s (still %.4f, rigid %.4f)",
        cfg.data.range_deg,
        len(train_rows),
        cfg.seed,
        cfg.cgpdm_name,
        table[f"error_{units}"].mean(),
        units,
        table[f"still_error_{units}"].mean(),
        table[f"rigid_error_{units}"].mean(),
    )


def tracking_observers(cfg: DictConfig, run_dir: Path) -> list[Any]:
    """The MCAP logger and, with ``tracking.rerun=save``, the mesh recording."""
    observers: list[Any] = [McapLogger(run_dir)] if cfg.tracking.mcap else []
    if rerun_mode(cfg) == "save":
        from mcpilco.tracking.mesh_stream import MeshRerunStreamer

        observers.append(MeshRerunStreamer(run_dir))
    return observers


@dataclass
class TestResults:
    """A trained model's predictions of the test set, its errors and timings."""

    test: ClothDataset
    latent: np.ndarray
    predicted: np.ndarray
    errors: dict[str, np.ndarray]
    train_seconds: float
    predict_seconds: float
    loss: float
    training_sequences: list[int]


def log_test_sequences(
    cfg: DictConfig, contract: RunContract, results: TestResults, finished: list[int]
) -> None:
    """Per test sequence not in ``finished``, to the MCAP log (and the Rerun recording):
    the true cloth (state) with the prediction (measurement), the latent trajectory; then
    its summary row. The finished sequences' log chunks are kept as they are."""
    storage, test = contract.storage, results.test
    observers = tracking_observers(cfg, storage.path)
    config_yaml = OmegaConf.to_yaml(cfg, resolve=True)
    done = [k for k, sequence in enumerate(test.indices) if int(sequence) in finished]
    if done != list(range(len(done))):
        raise RunFileError(
            f"{storage.path / 'summary.csv'} lists sequences {finished}, not a start of the "
            f"test set {test.indices.tolist()}"
        )
    for observer in observers:
        observer.run_started(run_metadata(config_yaml, cfg.seed, "cpu", "float64"), len(done) - 1)
    dt = float(cfg.cloth.sample_dt)
    distances = point_distance_per_step(test.observations, results.predicted)  # [S, N] m
    errors, units = results.errors, error_units(cfg)
    try:
        for k in range(len(done), len(test.indices)):
            row = {
                "trial": k,
                "sequence": int(test.indices[k]),
                "range_deg": cfg.data.range_deg,
                "num_train": len(results.training_sequences),
                "draw": cfg.seed,
                "variant": cfg.cgpdm_name,
                f"error_{units}": float(errors["model"][k]),
                f"still_error_{units}": float(errors["still"][k]),
                f"rigid_error_{units}": float(errors["rigid"][k]),
                "eval_cost": float(errors["model"][k]),
                "fit_seconds": results.train_seconds,
                "predict_seconds": results.predict_seconds,
                "final_loss": results.loss,
            }
            cloth = sequence_trajectory(
                test.observations[k], test.controls[k], dt, results.predicted[k]
            )
            latent = sequence_trajectory(results.latent[k], test.controls[k], dt)
            for observer in observers:
                observer.rollout(k, cloth, distances[k], distances[k], kind="cloth")
                observer.rollout(k, latent, distances[k], distances[k], kind="latent")
                observer.trial_finished(k, row)  # the log chunk first, the row last
            storage.append_summary(row, key=contract.kind.unit_key)
    finally:
        for observer in observers:
            observer.close()


def runner_for(cfg: DictConfig) -> Runner[Any]:
    return GENERATE_RUNNER if cfg.get("mode") == "generate" else CGPDM_RUNNER


CGPDM_RUNNER: Runner[CGPDMSetup] = Runner(
    kind=CGPDM_KIND, resume_overrides=("threads", "device"), prepare=prepare, work=work
)
GENERATE_RUNNER: Runner[Any] = Runner(
    kind=CLOTH_DATASETS,
    resume_overrides=("threads",),
    prepare=prepare_generation,
    work=generate_datasets,
)
