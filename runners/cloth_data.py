"""``runners.cgpdm mode=generate``: the cloth data sets of every range, written and checked
(and the pieces of config the generator and the training runs share)."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig, OmegaConf

from mcpilco.build import make
from mcpilco.cloth import ClothParameters, ClothSimulation, Excitation
from mcpilco.cloth.dataset import generate
from mcpilco.cloth.store import stability_report
from mcpilco.errors import ConfigError
from mcpilco.run_storage import RunDirectory
from mcpilco.safe_config import check_targets
from mcpilco.tracking import McapLogger
from mcpilco.tracking.metadata import run_metadata
from mcpilco.trajectory import Trajectory

log = logging.getLogger("mcpilco.cgpdm")


def excitation_from(cfg: DictConfig) -> Excitation:
    """``excitation.*`` checked: one-line errors naming the key."""
    node = cfg.excitation
    low, high = (float(f) for f in node.frequency_range)
    if not 0 < low <= high:
        raise ConfigError(
            f"excitation.frequency_range={list(node.frequency_range)} must be 0 < low <= high"
        )
    if not node.amplitude > 0:
        raise ConfigError(f"excitation.amplitude={node.amplitude!r} must be positive")
    if not isinstance(node.num_samples, int) or node.num_samples < 3:
        raise ConfigError(f"excitation.num_samples={node.num_samples!r} must be an integer >= 3")
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


def generate_datasets(cfg: DictConfig) -> None:
    """``mode=generate``: every range of ``data.ranges``, written and checked."""
    check_targets(cfg)
    cloth: ClothParameters = make(cfg.cloth)
    excitation = excitation_from(cfg)
    simulation = ClothSimulation(cloth)
    run_dir = Path(HydraConfig.get().runtime.output_dir)
    storage = RunDirectory(run_dir)
    with storage.locked():
        config_yaml = OmegaConf.to_yaml(cfg, resolve=True)
        storage.write_text("config.yaml", config_yaml)
        observers: list[Any] = [McapLogger(run_dir)] if cfg.tracking.mcap else []
        for observer in observers:
            observer.run_started(run_metadata(config_yaml, cfg.data.seed, "cpu", "float64"), -1)
        try:
            for index, range_deg in enumerate(cfg.data.ranges):
                dataset = generate(
                    simulation,
                    excitation,
                    float(range_deg),
                    int(cfg.data.seed),
                    range(int(cfg.data.num_sequences)),
                )
                dataset.save(run_dir / "datasets" / f"R{float(range_deg):g}.npz")
                report = stability_report(dataset, simulation)
                for k in range(len(dataset.indices)):
                    zero = np.zeros(dataset.observations.shape[1])
                    for observer in observers:
                        observer.rollout(
                            index * 1000 + k,
                            sequence_trajectory(
                                dataset.observations[k], dataset.controls[k], cloth.sample_dt
                            ),
                            zero,
                            zero,
                            kind=f"cloth_R{float(range_deg):g}",
                        )
                row = {
                    "trial": index,
                    "range_deg": float(range_deg),
                    "sequences": len(dataset.indices),
                    **report,
                }
                storage.append_summary(row)
                for observer in observers:
                    observer.trial_finished(index, row)
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
