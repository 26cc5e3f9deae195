"""One cell of the thesis's CGPDM study (§6.4.2–6.4.3): draw a training set, train, predict.

The last ``num_test`` sequences of a data set are its test set; training sets are drawn
without replacement from the others. Draw ``k`` is a random permutation seeded by k, and a
training set of n sequences is its first n: the sets of one draw are nested (5 ⊂ 10 ⊂ …),
so the error's change with n is not confounded with a change of sequences.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import torch

from mcpilco.cloth.dataset import ClothDataset
from mcpilco.errors import ConfigError
from mcpilco.latent.cgpdm import CGPDM, TrainingData
from mcpilco.latent.evaluation import point_distance, rigid_baseline, still_baseline
from mcpilco.latent.split import SequenceSplit
from mcpilco.latent.training import CGPDMTraining


def check_sizes(total: int, num_test: int, num_train: int) -> None:
    """One-line errors, naming the key, when the sizes cannot be drawn from ``total``."""
    if not isinstance(num_test, int) or not 1 <= num_test < total:
        raise ConfigError(
            f"data.num_test={num_test!r} must be in [1, {total - 1}] "
            f"(the data set has {total} sequences)"
        )
    available = total - num_test
    if not isinstance(num_train, int) or not 1 <= num_train <= available:
        raise ConfigError(
            f"data.num_train={num_train!r} must be in [1, {available}]: "
            f"{total} sequences minus {num_test} for test"
        )


def split(
    dataset: ClothDataset, num_test: int, num_train: int, draw: int
) -> tuple[list[int], list[int]]:
    """Row numbers of (training set, test set) by the default rules
    (:class:`~mcpilco.latent.split.SequenceSplit`); one-line errors on impossible sizes."""
    check_sizes(len(dataset.indices), num_test, num_train)
    return SequenceSplit(num_train, num_test, draw).rows(dataset)


@dataclass
class CellResult:
    """Per test sequence: errors of the model and of the baselines (m); timings (s)."""

    errors: np.ndarray
    still_errors: np.ndarray
    rigid_errors: np.ndarray
    latent: np.ndarray
    predicted: np.ndarray
    train_seconds: float
    predict_seconds_per_sequence: float
    final_loss: float


def training_data(training: ClothDataset, device: torch.device | str = "cpu") -> TrainingData:
    return TrainingData(
        torch.as_tensor(training.observations, device=device),
        torch.as_tensor(training.controls, device=device),
    )


def train(model: CGPDM, fit: CGPDMTraining) -> tuple[list[float], float]:
    """Train a model whose data are set; (loss after each outer step, wall seconds)."""
    start = time.perf_counter()
    trace = fit(model)
    return trace, time.perf_counter() - start


def evaluate(model: CGPDM, test: ClothDataset) -> tuple[np.ndarray, np.ndarray, float]:
    """Predict every test sequence from the common initial state: (latent [S, N, d],
    observations [S, N, D], seconds per sequence)."""
    start = time.perf_counter()
    controls = torch.as_tensor(test.controls, device=model.latent_states.device)
    latent, predicted = (tensor.cpu().numpy() for tensor in model.predict(controls))
    seconds = (time.perf_counter() - start) / len(test.indices)  # after the copy: synchronised
    return latent, predicted, seconds


def score(test: ClothDataset, predicted: np.ndarray) -> dict[str, np.ndarray]:
    """Eq. 6.13 per test sequence for the model and the two baselines."""
    return {
        "model": point_distance(test.observations, predicted),
        "still": point_distance(test.observations, still_baseline(test.observations)),
        "rigid": point_distance(
            test.observations, rigid_baseline(test.observations, test.controls)
        ),
    }
