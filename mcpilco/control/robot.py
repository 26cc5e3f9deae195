"""Robots under joint-torque control (thesis chapter 5): the interface (a PyBullet arm:
:mod:`mcpilco.control.pybullet_arm`)."""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from mcpilco.extension import ExtensionPoint


class TorqueControlledRobot(ExtensionPoint, ABC):
    """An n-joint manipulator driven by joint torques τ (N m) held over each step of ``dt``
    seconds, with its true rigid-body model (for the reference controller and tests).

    Joint positions q (rad), velocities q̇ (rad/s), accelerations q̈ (rad/s²) are ``[n]``.
    """

    num_joints: int
    dt: float
    torque_limits: np.ndarray | None = None
    """|τ_j| ≤ limit_j ``[n]`` (N m) on every step, or None (no limit)."""
    home: np.ndarray | None = None
    """The rest configuration ``[n]`` (rad) data collection excites around (None: zeros)."""

    @property
    def name(self) -> str:
        """What the robot is (a model file fitted to one robot refuses another)."""
        return type(self).__name__

    @abstractmethod
    def reset(self, positions: np.ndarray, velocities: np.ndarray) -> None:
        """Put the robot at ``(q, q̇)``."""

    @abstractmethod
    def step(self, torques: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Apply ``τ [n]`` for one step; return the new ``(q, q̇)``."""

    @abstractmethod
    def inverse_dynamics(
        self, positions: np.ndarray, velocities: np.ndarray, accelerations: np.ndarray
    ) -> np.ndarray:
        """τ = B(q) q̈ + n(q, q̇) ``[n]`` of the true model."""

    @abstractmethod
    def mass_matrix(self, positions: np.ndarray) -> np.ndarray:
        """B(q) ``[n, n]``."""

    def limited(self, torques: np.ndarray) -> np.ndarray:
        """``τ [..., n]`` clipped to the torque limits (what the actuators apply)."""
        if self.torque_limits is None:
            return np.asarray(torques, dtype=np.float64)
        return np.clip(torques, -self.torque_limits, self.torque_limits)

    def gravity_torques(self, positions: np.ndarray) -> np.ndarray:
        """g(q) ``[n]`` = τ at rest with zero acceleration."""
        zero = np.zeros(self.num_joints)
        return self.inverse_dynamics(positions, zero, zero)
