"""The record of one interaction with a system."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Trajectory:
    """One rollout on the system, sampled every ``dt`` seconds.

    Attributes:
        states: true states ``[T+1, d_x]`` (SI units, angles in rad, not wrapped).
        measurements: what the sensors returned ``[T+1, d_y]`` (noisy, possibly partial).
        actions: inputs applied ``[T, d_u]``, held constant over each sample (ZOH).
        dt: sampling time in seconds.
        rewards: the environment's reward after each action ``[T]`` (Gymnasium
            environments), None for systems that give none.
    """

    states: np.ndarray
    measurements: np.ndarray
    actions: np.ndarray
    dt: float
    rewards: np.ndarray | None = None

    def __post_init__(self) -> None:
        steps = self.actions.shape[0]
        if self.states.shape[0] != steps + 1 or self.measurements.shape[0] != steps + 1:
            raise ValueError(
                f"trajectory lengths disagree: states {self.states.shape}, "
                f"measurements {self.measurements.shape}, actions {self.actions.shape}"
            )
        if self.rewards is not None and self.rewards.shape != (steps,):
            raise ValueError(
                f"trajectory lengths disagree: rewards {self.rewards.shape}, "
                f"actions {self.actions.shape}"
            )

    @property
    def num_steps(self) -> int:
        """Number of control steps T."""
        return int(self.actions.shape[0])

    @property
    def times(self) -> np.ndarray:
        """Sample times ``[T+1]`` in seconds."""
        return np.arange(self.num_steps + 1) * self.dt

    def as_arrays(self) -> dict[str, np.ndarray]:
        """Plain arrays, for ``np.savez`` (``rewards`` only where there are some)."""
        arrays = {
            "states": self.states,
            "measurements": self.measurements,
            "actions": self.actions,
            "dt": np.asarray(self.dt),
        }
        if self.rewards is not None:
            arrays["rewards"] = self.rewards
        return arrays

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> Trajectory:
        """Inverse of :meth:`as_arrays`."""
        return cls(
            states=np.asarray(arrays["states"]),
            measurements=np.asarray(arrays["measurements"]),
            actions=np.asarray(arrays["actions"]),
            dt=float(arrays["dt"]),
            rewards=np.asarray(arrays["rewards"]) if "rewards" in arrays else None,
        )
