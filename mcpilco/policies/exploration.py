"""Exploration controllers for the first rollout."""

from __future__ import annotations

import numpy as np


class UniformRandomExploration:
    """u_t ~ U(−u_max, u_max), independently per step and component (thesis §2.5).

    Args:
        u_max: bound of the uniform distribution.
        action_dim: d_u.
        rng: random source (the system's).
    """

    def __init__(self, u_max: float, action_dim: int, rng: np.random.Generator) -> None:
        self.u_max = u_max
        self.action_dim = action_dim
        self.rng = rng

    def __call__(self, measurement: np.ndarray, step: int) -> np.ndarray:
        return self.rng.uniform(-self.u_max, self.u_max, size=self.action_dim)
