"""Inverse-dynamics data (thesis §5.4.1): a PD controller tracks random joint references."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mcpilco.checks import positive
from mcpilco.control.references import filtered_noise
from mcpilco.control.robot import TorqueControlledRobot
from mcpilco.errors import ConfigError


@dataclass
class InverseDynamicsData:
    """Samples of the inverse dynamics: ``q, q̇, q̈, τ`` ``[N, n]`` each (rad, rad/s,
    rad/s², N m), and the sample time ``dt`` (s)."""

    positions: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray
    torques: np.ndarray
    dt: float

    @property
    def inputs(self) -> np.ndarray:
        """GP inputs ``[N, 3n]`` = [q, q̇, q̈]."""
        return np.concatenate([self.positions, self.velocities, self.accelerations], axis=1)

    def as_arrays(self) -> dict[str, np.ndarray]:
        return {
            "positions": self.positions,
            "velocities": self.velocities,
            "accelerations": self.accelerations,
            "torques": self.torques,
            "dt": np.asarray(self.dt),
        }

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> InverseDynamicsData:
        return cls(
            arrays["positions"],
            arrays["velocities"],
            arrays["accelerations"],
            arrays["torques"],
            float(arrays["dt"]),
        )


def collect(
    robot: TorqueControlledRobot,
    rng: np.random.Generator,
    duration: float = 50.0,
    downsample: int = 10,
    cutoff_hz: float = 1.0,
    reference_std: float | Sequence[float] = 0.5,
    kp: float | Sequence[float] = 300.0,
    kd: float | Sequence[float] = 30.0,
    torque_limit: float = 300.0,
) -> InverseDynamicsData:
    """Run a PD controller τ = K_P (r − q) + K_D (ṙ − q̇) (clipped to ±``torque_limit``
    and to the robot's own limits) on a filtered-noise reference around the robot's
    ``home`` (zeros when it has none) for ``duration`` s at the robot's rate;
    accelerations by central differences of the velocities; every ``downsample``-th
    sample kept.

    Returns samples whose τ_t (the torque applied, after both clips) acted at (q_t, q̇_t)
    and q̈_t = (q̇_{t+1} − q̇_{t−1}) / 2dt.
    """
    positive("duration", duration, "data")
    if not isinstance(downsample, int) or downsample < 1:
        raise ConfigError(f"data.downsample={downsample!r} must be a positive integer")
    n, dt = robot.num_joints, robot.dt
    steps = int(round(duration / dt))
    reference = filtered_noise(rng, steps + 2, n, dt, cutoff_hz, reference_std)
    if robot.home is not None:
        reference = reference + robot.home
    reference_velocity = np.gradient(reference, dt, axis=0)
    gains_p = np.broadcast_to(np.asarray(kp, dtype=np.float64), (n,))
    gains_d = np.broadcast_to(np.asarray(kd, dtype=np.float64), (n,))
    positions = np.empty((steps + 2, n))
    velocities = np.empty((steps + 2, n))
    torques = np.empty((steps + 1, n))
    robot.reset(reference[0], np.zeros(n))
    positions[0], velocities[0] = reference[0], 0.0
    for t in range(steps + 1):
        error = reference[t] - positions[t]
        torque = gains_p * error + gains_d * (reference_velocity[t] - velocities[t])
        torques[t] = robot.limited(np.clip(torque, -torque_limit, torque_limit))
        positions[t + 1], velocities[t + 1] = robot.step(torques[t])
    accelerations = (velocities[2:] - velocities[:-2]) / (2 * dt)  # at samples 1..steps
    keep = np.arange(1, steps + 1, downsample)
    return InverseDynamicsData(
        positions[keep], velocities[keep], accelerations[keep - 1], torques[keep], dt * downsample
    )
