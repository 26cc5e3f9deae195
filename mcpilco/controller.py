"""Closed-loop controller that runs a learned policy on the system."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mcpilco.estimators.base import StateEstimator
from mcpilco.models.base import ModelStructure
from mcpilco.policies.rbf import SquashedRBFPolicy


class PolicyController:
    """measurement → online estimator → policy input → deterministic policy (no dropout)."""

    def __init__(
        self, policy: SquashedRBFPolicy, model: ModelStructure, estimator: StateEstimator
    ) -> None:
        self.policy = policy
        self.model = model
        self.estimator = estimator
        self._like = next(policy.parameters())
        self._memory: Any = estimator.online_reset(1, self._like)

    @torch.no_grad()
    def __call__(self, measurement: np.ndarray, step: int) -> np.ndarray:
        if step == 0:
            self._memory = self.estimator.online_reset(1, self._like)
        reading = torch.as_tensor(measurement, dtype=self._like.dtype, device=self._like.device)
        estimate, self._memory = self.estimator.online_step(reading[None], self._memory)
        action = self.policy(self.model.policy_inputs(estimate))
        return action[0].cpu().numpy()
