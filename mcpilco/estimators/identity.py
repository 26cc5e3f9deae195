"""Full-state measurement: every component measured, no filtering (``estimator=none``)."""

from __future__ import annotations

import numpy as np
import torch

from mcpilco.estimators.base import StateEstimator
from mcpilco.systems.base import MechanicalSystem


class FullStateMeasurement(StateEstimator):
    """The estimate is the raw reading, offline and online. State-based models need every
    component measured (checked by :meth:`ModelStructure.check_estimator`); the
    derivative-free model takes position readings as they are.

    Args:
        system: accepted for a uniform constructor (all estimators are built with it).
    """

    def __init__(self, system: MechanicalSystem | None = None) -> None:
        self.system = system

    def offline(
        self, measurements: np.ndarray, dt: float, actions: np.ndarray | None = None
    ) -> np.ndarray:
        return measurements

    def online_reset(self, batch_size: int, like: torch.Tensor) -> None:
        return None

    def online_step(self, measurement: torch.Tensor, memory: None) -> tuple[torch.Tensor, None]:
        return measurement, None

    @property
    def is_identity(self) -> bool:
        return True
