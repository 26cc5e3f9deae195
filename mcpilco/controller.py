"""Closed-loop controller that runs a learned policy on the system."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mcpilco.estimators.base import StateEstimator
from mcpilco.models.base import ModelStructure
from mcpilco.policies.rbf import SquashedRBFPolicy


class PolicyController:
    """measurement → online estimator → the model's closed-loop state (a history for the
    derivative-free structure) → policy input → deterministic policy (no dropout)."""

    def __init__(
        self, policy: SquashedRBFPolicy, model: ModelStructure, estimator: StateEstimator
    ) -> None:
        self.policy = policy
        self.model = model
        self.estimator = estimator
        self._like = next(policy.parameters())
        self._memory: Any = estimator.online_reset(1, self._like)
        self._state: torch.Tensor | None = None
        self._action: torch.Tensor | None = None

    @torch.no_grad()
    def __call__(self, measurement: np.ndarray, step: int) -> np.ndarray:
        if step == 0:
            self._memory = self.estimator.online_reset(1, self._like)
            self._state = self._action = None
        reading = torch.as_tensor(measurement, dtype=self._like.dtype, device=self._like.device)
        estimate, self._memory = self.estimator.online_step(reading[None], self._memory)
        self._state = self.model.closed_loop_state(self._state, estimate, self._action)
        inputs = self.model.with_tracking_errors(
            self.model.policy_inputs(self._state), estimate, step
        )
        self._action = self.policy(inputs)
        return self._action[0].cpu().numpy()
