"""The estimator interface (MC-PILCO4PMS, thesis §3.2).

An estimator has two parts. The *offline* part turns a whole recorded measurement sequence
into the states the GPs are trained on (acausal filters allowed). The *online* part runs
causally, step by step, batched over particles and differentiable in torch; it is used in
closed loop on the system and, during policy optimisation, on each simulated particle.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any

import numpy as np
import torch

from mcpilco.extension import ExtensionPoint


class StateEstimator(ExtensionPoint, ABC):
    """Offline and online state estimation from measurements."""

    @abstractmethod
    def offline(
        self, measurements: np.ndarray, dt: float, actions: np.ndarray | None = None
    ) -> np.ndarray:
        """States ``[T+1, d_x]`` estimated from a whole trajectory of measurements
        ``[T+1, d_y]``; ``actions [T, d_u]`` are the inputs held between the readings (used
        by estimators that model them, ignored by the others)."""

    @abstractmethod
    def online_reset(self, batch_size: int, like: torch.Tensor) -> Any:
        """Fresh internal state for ``batch_size`` independent streams."""

    @abstractmethod
    def online_step(self, measurement: torch.Tensor, memory: Any) -> tuple[torch.Tensor, Any]:
        """Estimate ``[B, d_x]`` from the newest measurement ``[B, d_x]``; new memory."""

    @property
    def is_identity(self) -> bool:
        """True when the estimate is the measurement itself (lets rollouts skip the call)."""
        return False
