"""Robots under joint-torque control (thesis chapter 5): the interface and a PyBullet arm."""

from __future__ import annotations

import os
from abc import ABC, abstractmethod
from collections.abc import Sequence

import numpy as np

from mcpilco.checks import non_negative, positive, require_finite
from mcpilco.errors import ConfigError
from mcpilco.extension import ExtensionPoint


class TorqueControlledRobot(ExtensionPoint, ABC):
    """An n-joint manipulator driven by joint torques τ (N m) held over each step of ``dt``
    seconds, with its true rigid-body model (for the reference controller and tests).

    Joint positions q (rad), velocities q̇ (rad/s), accelerations q̈ (rad/s²) are ``[n]``.
    """

    num_joints: int
    dt: float

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

    def gravity_torques(self, positions: np.ndarray) -> np.ndarray:
        """g(q) ``[n]`` = τ at rest with zero acceleration."""
        zero = np.zeros(self.num_joints)
        return self.inverse_dynamics(positions, zero, zero)


class PyBulletArm(TorqueControlledRobot):
    """A fixed-base arm from a URDF simulated by PyBullet in DIRECT mode (never a GUI),
    under pure torque control: the default velocity motors are switched off and the torque
    command is re-sent every step (PyBullet applies it for one step only).

    PyBullet's inverse dynamics ignores joint and link damping, so link damping is set to
    zero and joint damping is ``joint_damping`` (0 by default: the true model is then
    exact; the URDF's own 0.5 N m s/rad makes PyBullet's model miss the acceleration).
    Inertias are read from the URDF (``URDF_USE_INERTIA_FROM_FILE``), not from collision
    shapes.

    Args:
        urdf: path relative to ``pybullet_data`` (or absolute).
        num_joints: the revolute joints the URDF must hold (checked).
        dt: simulation and control step in s (1 kHz by default).
        gravity: m/s² along −z.
        joint_damping: viscous damping of every joint, N m s/rad (unmodelled by the
            true-model controller when > 0).
    """

    def __init__(
        self,
        urdf: str = "kuka_iiwa/model.urdf",
        num_joints: int = 7,
        dt: float = 1e-3,
        gravity: float = 9.81,
        joint_damping: float = 0.0,
    ) -> None:
        import pybullet
        import pybullet_data

        self.dt = positive("dt", dt, "robot")
        self.joint_damping = float(non_negative("joint_damping", joint_damping, "robot"))
        if not isinstance(urdf, str) or not urdf:
            raise ConfigError(f"robot.urdf={urdf!r} must be a URDF file name")
        path = urdf if os.path.isabs(urdf) else os.path.join(pybullet_data.getDataPath(), urdf)
        if not os.path.isfile(path):
            raise ConfigError(f"robot.urdf={urdf!r}: no such file ({path})")
        self._pb = pybullet
        self._client = pybullet.connect(pybullet.DIRECT)
        self._urdf = urdf
        self._body = pybullet.loadURDF(
            path,
            useFixedBase=True,
            flags=pybullet.URDF_USE_INERTIA_FROM_FILE,
            physicsClientId=self._client,
        )
        joints = [
            j
            for j in range(pybullet.getNumJoints(self._body, physicsClientId=self._client))
            if pybullet.getJointInfo(self._body, j, physicsClientId=self._client)[2]
            == pybullet.JOINT_REVOLUTE
        ]
        if not isinstance(num_joints, int) or num_joints != len(joints):
            self.close()
            raise ConfigError(
                f"robot.num_joints={num_joints!r} but {urdf} has {len(joints)} revolute joints"
            )
        self.num_joints, self._joints = num_joints, joints
        pybullet.setGravity(
            0, 0, -float(non_negative("gravity", gravity, "robot")), physicsClientId=self._client
        )
        pybullet.setTimeStep(self.dt, physicsClientId=self._client)
        for joint in [-1, *joints]:
            pybullet.changeDynamics(
                self._body,
                joint,
                linearDamping=0.0,
                angularDamping=0.0,
                jointDamping=self.joint_damping,
                physicsClientId=self._client,
            )
        pybullet.setJointMotorControlArray(
            self._body,
            joints,
            pybullet.VELOCITY_CONTROL,
            forces=[0.0] * num_joints,
            physicsClientId=self._client,
        )

    @property
    def name(self) -> str:
        return f"PyBulletArm({self._urdf}, {self.num_joints} joints)"

    @staticmethod
    def _floats(values: np.ndarray | Sequence[float]) -> list[float]:
        """PyBullet's dynamics calls can crash the process on numpy arrays: plain floats."""
        return [float(v) for v in np.asarray(values, dtype=np.float64).ravel()]

    def reset(self, positions: np.ndarray, velocities: np.ndarray) -> None:
        for joint, q, qd in zip(
            self._joints, self._floats(positions), self._floats(velocities), strict=True
        ):
            self._pb.resetJointState(self._body, joint, q, qd, physicsClientId=self._client)

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """Current ``(q, q̇)``."""
        states = self._pb.getJointStates(self._body, self._joints, physicsClientId=self._client)
        return (
            np.array([s[0] for s in states], dtype=np.float64),
            np.array([s[1] for s in states], dtype=np.float64),
        )

    def step(self, torques: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        require_finite(np.asarray(torques, dtype=np.float64), "the torque", None)
        self._pb.setJointMotorControlArray(
            self._body,
            self._joints,
            self._pb.TORQUE_CONTROL,
            forces=self._floats(torques),
            physicsClientId=self._client,
        )
        self._pb.stepSimulation(physicsClientId=self._client)
        return self.state()

    def inverse_dynamics(
        self, positions: np.ndarray, velocities: np.ndarray, accelerations: np.ndarray
    ) -> np.ndarray:
        torques = self._pb.calculateInverseDynamics(
            self._body,
            self._floats(positions),
            self._floats(velocities),
            self._floats(accelerations),
            physicsClientId=self._client,
        )
        return np.asarray(torques, dtype=np.float64)

    def mass_matrix(self, positions: np.ndarray) -> np.ndarray:
        matrix = self._pb.calculateMassMatrix(
            self._body, self._floats(positions), physicsClientId=self._client
        )
        return np.asarray(matrix, dtype=np.float64)

    def close(self) -> None:
        """Disconnect from PyBullet (also on garbage collection)."""
        if getattr(self, "_client", None) is not None:
            try:
                self._pb.disconnect(physicsClientId=self._client)
            except Exception:  # already gone at interpreter exit
                pass
            self._client = None

    def __del__(self) -> None:
        self.close()
