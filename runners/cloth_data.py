"""``runners.cgpdm mode=generate``: the cloth data sets of every range, written and checked
(and the pieces of config the generator and the training runs share)."""

from __future__ import annotations

import logging
from typing import Any

import numpy as np
from omegaconf import DictConfig, OmegaConf

from mcpilco.build import make
from mcpilco.cloth import ClothDataset, ClothParameters, ClothSimulation, Excitation
from mcpilco.cloth.dataset import generate
from mcpilco.cloth.store import stability_report
from mcpilco.run_contract import RunContract
from mcpilco.safe_config import check_targets
from mcpilco.tracking import McapLogger
from mcpilco.tracking.metadata import run_metadata
from mcpilco.trajectory import Trajectory
from runners.cgpdm_checks import check_cgpdm_config

log = logging.getLogger("mcpilco.cgpdm")


def excitation_from(cfg: DictConfig) -> Excitation:
    """``excitation.*`` as an :class:`Excitation` (its keys checked by
    :func:`runners.cgpdm_checks.check_cgpdm_config` first)."""
    node = cfg.excitation
    low, high = (float(f) for f in node.frequency_range)
    return Excitation(float(node.amplitude), (low, high), int(node.num_samples))


def sequence_trajectory(
    observations: np.ndarray, controls: np.ndarray, dt: float, measured: np.ndarray | None = None
) -> Trajectory:
    return Trajectory(
        states=observations,
        measurements=observations if measured is None else measured,
        actions=controls,
        dt=dt,
    )


def prepare_generation(cfg: DictConfig) -> tuple[ClothParameters, Excitation]:
    """``mode=generate``: every key checked, the cloth and excitation built; nothing
    simulated yet."""
    check_targets(cfg)
    check_cgpdm_config(cfg)
    return make(cfg.cloth), excitation_from(cfg)


def generate_datasets(
    cfg: DictConfig,
    built: tuple[ClothParameters, Excitation],
    contract: RunContract,
    finished: list[Any],
) -> None:
    """``mode=generate``: every range of ``data.ranges`` not yet in the summary simulated,
    written (``datasets/R<R>.npz`` + ``.json``) and checked; the log holds every data set's
    sequences (those made before are read back from their files, not simulated again)."""
    cloth, excitation = built
    simulation = ClothSimulation(cloth)
    storage = contract.storage
    done = {float(r) for r in finished}
    config_yaml = OmegaConf.to_yaml(cfg, resolve=True)
    observers: list[Any] = [McapLogger(storage.path)] if cfg.tracking.mcap else []
    for observer in observers:  # the log is written anew: from the files, then simulated
        observer.run_started(run_metadata(config_yaml, cfg.data.seed, "cpu", "float64"), -1)
    try:
        for index, range_deg in enumerate(float(r) for r in cfg.data.ranges):
            path = storage.path / "datasets" / f"R{range_deg:g}.npz"
            if range_deg in done:
                dataset = ClothDataset.load(path)
            else:
                dataset = generate(
                    simulation, excitation, range_deg, int(cfg.data.seed),
                    range(int(cfg.data.num_sequences)),
                )  # fmt: skip
                dataset.save(path)
            report = stability_report(dataset, simulation)
            for k in range(len(dataset.indices)):
                zero = np.zeros(dataset.observations.shape[1])
                trajectory = sequence_trajectory(
                    dataset.observations[k], dataset.controls[k], cloth.sample_dt
                )
                for observer in observers:
                    observer.rollout(
                        index * 1000 + k, trajectory, zero, zero, kind=f"cloth_R{range_deg:g}"
                    )
            row = {
                "trial": index,
                "range_deg": range_deg,
                "sequences": len(dataset.indices),
                **report,
            }
            for observer in observers:  # the log chunk first, the row last
                observer.trial_finished(index, row)
            storage.append_summary(row, key=contract.kind.unit_key)
            log.info(
                "R=%g: %d sequences, largest edge stretch %.2f %%, farthest vertex "
                "%.3f m from the grip",
                range_deg,
                len(dataset.indices),
                100 * report["max_edge_stretch"],
                report["max_distance_from_grip_m"],
            )
    finally:
        for observer in observers:
            observer.close()
