"""Full-state measurement: every component measured, no filtering (``estimator=none``)."""

from __future__ import annotations

import numpy as np
import torch

from mcpilco.estimators.base import StateEstimator


class FullStateMeasurement(StateEstimator):
    """The estimate is the measurement, offline and online."""

    def offline(self, measurements: np.ndarray, dt: float) -> np.ndarray:
        return measurements

    def online_reset(self, batch_size: int, like: torch.Tensor) -> None:
        return None

    def online_step(self, measurement: torch.Tensor, memory: None) -> tuple[torch.Tensor, None]:
        return measurement, None

    @property
    def is_identity(self) -> bool:
        return True
