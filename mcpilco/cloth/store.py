"""Generated data sets on disk: one file per (cloth, excitation, R, seed), made once."""

from __future__ import annotations

import hashlib
import json
import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mcpilco.cloth.dataset import ClothDataset, Excitation, generate
from mcpilco.cloth.simulation import ClothParameters, ClothSimulation
from mcpilco.errors import ConfigError

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class DatasetKey:
    """What names a simulated data set: the cloth, the excitation, R, the seed and the
    number of sequences."""

    parameters: ClothParameters
    excitation: Excitation
    range_deg: float
    seed: int
    num_sequences: int

    def path(self, directory: Path) -> Path:
        """``directory/R<R>_seed<seed>_<hash of cloth, excitation and size>.npz``."""
        facts = {
            "cloth": self.parameters.fingerprint(),
            "excitation": self.excitation.facts(),
            "num_sequences": self.num_sequences,
        }
        digest = hashlib.sha256(json.dumps(facts, sort_keys=True).encode()).hexdigest()[:10]
        return directory / f"R{self.range_deg:g}_seed{self.seed}_{digest}.npz"


def check_compatible(
    dataset: ClothDataset,
    parameters: ClothParameters,
    excitation: Excitation,
    range_deg: float,
    source: str,
) -> None:
    """One-line :class:`ConfigError` naming the first fact in which a simulated data set
    differs from the configured cloth, excitation or range."""
    metadata = dataset.metadata
    if "cloth" not in metadata:
        return  # read from CSV: nothing to compare
    expected = {
        **{f"cloth.{k}": v for k, v in parameters.fingerprint().items()},
        **{f"excitation.{k}": v for k, v in excitation.facts().items()},
        "data.range_deg": float(range_deg),
    }
    found = {
        **{f"cloth.{k}": v for k, v in metadata["cloth"].items()},
        **{f"excitation.{k}": v for k, v in metadata.get("excitation", {}).items()},
        "data.range_deg": metadata.get("range_deg"),
    }
    for key, value in expected.items():
        if found.get(key) != value:
            raise ConfigError(
                f"data set {source} was made with {key}={found.get(key)!r}, the config has "
                f"{value!r}"
            )


def load_or_generate(directory: Path, key: DatasetKey) -> tuple[ClothDataset, Path]:
    """The data set ``key`` names: read from ``directory`` when there, else simulated and
    written there (atomically)."""
    path = key.path(directory)
    if path.exists():
        try:
            dataset = ClothDataset.load(path)
        except ConfigError as error:  # a damaged cache entry (a kill, a full disk): redo it
            log.warning("%s; simulating it again", error)
        else:
            check_compatible(dataset, key.parameters, key.excitation, key.range_deg, str(path))
            return dataset, path
    log.info(
        "simulating data set R=%g seed=%d (%d sequences) -> %s",
        key.range_deg, key.seed, key.num_sequences, path,
    )  # fmt: skip
    dataset = generate(
        ClothSimulation(key.parameters), key.excitation, key.range_deg, key.seed,
        range(key.num_sequences),
    )  # fmt: skip
    dataset.save(path)
    return dataset, path


def stability_report(dataset: ClothDataset, simulation: ClothSimulation) -> dict[str, float]:
    """Largest relative edge stretch and largest vertex distance from the mean end-effector
    position over a data set (an exploded simulation shows in both)."""
    vertices = dataset.observations.reshape(*dataset.observations.shape[:2], -1, 3)
    edges = simulation.edges()
    rest_length = simulation.parameters.side / 7.0
    lengths = np.linalg.norm(vertices[:, :, edges[:, 0]] - vertices[:, :, edges[:, 1]], axis=-1)
    corners = vertices[:, :, list(simulation.corner_vertices)].mean(axis=2, keepdims=True)
    return {
        "max_edge_stretch": float(lengths.max() / rest_length - 1.0),
        "mean_edge_stretch": float(lengths.mean() / rest_length - 1.0),
        "max_distance_from_grip_m": float(np.linalg.norm(vertices - corners, axis=-1).max()),
    }
