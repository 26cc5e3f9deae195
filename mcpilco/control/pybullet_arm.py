"""A fixed-base arm from a URDF, simulated by PyBullet in DIRECT mode (never a GUI)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import numpy as np

from mcpilco.checks import non_negative, positive, require_finite
from mcpilco.control.robot import TorqueControlledRobot
from mcpilco.errors import ConfigError

HELD_JOINT_FORCE = 1000.0
"""N (or N m): the holding motor's force for a held joint whose URDF gives no effort."""


class PyBulletArm(TorqueControlledRobot):
    """A URDF arm under pure torque control: the default velocity motors of the
    controlled joints are switched off and the torque command is re-sent every step
    (PyBullet applies it for one step only), clipped to ``torque_limit``.

    The controlled joints are ``joints`` (names) or, by default, every revolute joint.
    Every other movable joint (a gripper's fingers, a prismatic joint not named) is
    *held*: a PyBullet position motor keeps it at its hold position (0 clamped into its
    limits), and the true model (inverse dynamics, mass matrix) sees it there at rest.
    Spherical and planar joints are refused.

    PyBullet's inverse dynamics ignores joint and link damping, so link damping is set to
    zero and joint damping is ``joint_damping`` (0 by default: the true model is then
    exact). Inertias are read from the URDF (``URDF_USE_INERTIA_FROM_FILE``).

    Args:
        urdf: path relative to ``pybullet_data`` (or absolute).
        num_joints: how many joints are controlled (checked against the URDF).
        joints: names of the controlled joints, in order (null: the revolute joints).
        dt: simulation and control step in s (1 kHz by default).
        gravity: m/s² along −z.
        joint_damping: viscous damping of every joint, N m s/rad (unmodelled by the
            true-model controller when > 0).
        torque_limit: ``"urdf"`` (each joint's effort limit), a number or one per joint
            (N m), or null (no limit).
        home: rest configuration of the controlled joints (rad; null: zeros).
    """

    def __init__(
        self,
        urdf: str = "kuka_iiwa/model.urdf",
        num_joints: int = 7,
        joints: Sequence[str] | None = None,
        dt: float = 1e-3,
        gravity: float = 9.81,
        joint_damping: float = 0.0,
        torque_limit: str | float | Sequence[float] | None = "urdf",
        home: Sequence[float] | None = None,
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
        self._urdf, self._joint_names, self._limit_setting = urdf, joints, torque_limit
        self._client = pybullet.connect(pybullet.DIRECT)
        try:
            self._body = pybullet.loadURDF(
                path,
                useFixedBase=True,
                flags=pybullet.URDF_USE_INERTIA_FROM_FILE,
                physicsClientId=self._client,
            )
            self._setup(num_joints, joints, torque_limit, home, gravity)
        except BaseException:
            self.close()
            raise

    # ------------------------------------------------------------------ set-up
    def _joint_table(self) -> list[dict[str, Any]]:
        pb = self._pb
        table = []
        for j in range(pb.getNumJoints(self._body, physicsClientId=self._client)):
            info = pb.getJointInfo(self._body, j, physicsClientId=self._client)
            table.append(
                {
                    "index": j,
                    "name": info[1].decode(),
                    "type": info[2],
                    "lower": info[8],
                    "upper": info[9],
                    "effort": info[10],
                }
            )
        return table

    def _setup(
        self,
        num_joints: int,
        names: Sequence[str] | None,
        torque_limit: Any,
        home: Sequence[float] | None,
        gravity: float,
    ) -> None:
        pb, urdf = self._pb, self._urdf
        table = self._joint_table()
        for joint in table:
            if joint["type"] in (pb.JOINT_SPHERICAL, pb.JOINT_PLANAR):
                raise ConfigError(
                    f"robot.urdf={urdf!r}: joint {joint['name']!r} is spherical or planar; only "
                    "revolute and prismatic joints are supported"
                )
        movable = [j for j in table if j["type"] != pb.JOINT_FIXED]
        if names is None:
            controlled = [j for j in movable if j["type"] == pb.JOINT_REVOLUTE]
        else:
            by_name = {j["name"]: j for j in movable}
            if isinstance(names, str) or len(set(names)) != len(names):
                raise ConfigError(f"robot.joints={names!r} must be a list of distinct joint names")
            unknown = [n for n in names if n not in by_name]
            if unknown:
                raise ConfigError(
                    f"robot.joints names {unknown[0]!r}, not a movable joint of {urdf} "
                    f"(movable: {', '.join(by_name)})"
                )
            controlled = [by_name[n] for n in names]
        if not isinstance(num_joints, int) or num_joints != len(controlled):
            raise ConfigError(
                f"robot.num_joints={num_joints!r} but {urdf} has {len(controlled)} "
                + ("named joints" if names is not None else "revolute joints")
            )
        self.num_joints = num_joints
        self._joints = [j["index"] for j in controlled]
        held = [j for j in movable if j not in controlled]
        self._held = [j["index"] for j in held]
        self._hold_positions = [
            float(np.clip(0.0, j["lower"], j["upper"])) if j["lower"] < j["upper"] else 0.0
            for j in held
        ]
        dof = {j["index"]: i for i, j in enumerate(movable)}
        self._dofs = len(movable)
        self._controlled_dof = np.array([dof[j] for j in self._joints])
        self._held_dof = np.array([dof[j] for j in self._held], dtype=int)
        self.torque_limits = self._limits(torque_limit, controlled)
        self.home = None if home is None else self._per_joint("home", home)
        pb.setGravity(
            0, 0, -float(non_negative("gravity", gravity, "robot")), physicsClientId=self._client
        )
        pb.setTimeStep(self.dt, physicsClientId=self._client)
        for joint in [-1, *self._joints, *self._held]:
            pb.changeDynamics(
                self._body,
                joint,
                linearDamping=0.0,
                angularDamping=0.0,
                jointDamping=self.joint_damping,
                physicsClientId=self._client,
            )
        pb.setJointMotorControlArray(
            self._body,
            self._joints,
            pb.VELOCITY_CONTROL,
            forces=[0.0] * num_joints,
            physicsClientId=self._client,
        )
        if held:
            pb.setJointMotorControlArray(
                self._body,
                self._held,
                pb.POSITION_CONTROL,
                targetPositions=self._hold_positions,
                forces=[j["effort"] if j["effort"] > 0 else HELD_JOINT_FORCE for j in held],
                physicsClientId=self._client,
            )

    def _per_joint(self, key: str, value: Any) -> np.ndarray:
        if isinstance(value, str) or not hasattr(value, "__len__") or len(value) != self.num_joints:
            raise ConfigError(f"robot.{key}={value!r} must be a list of {self.num_joints} numbers")
        try:
            array = np.array([float(v) for v in value])
        except (TypeError, ValueError):
            raise ConfigError(
                f"robot.{key}={value!r} must be a list of {self.num_joints} numbers"
            ) from None
        if not np.all(np.isfinite(array)):
            raise ConfigError(f"robot.{key}={value!r} must be finite")
        return array

    def _limits(self, setting: Any, controlled: list[dict[str, Any]]) -> np.ndarray | None:
        if setting is None:
            return None
        if setting == "urdf":
            efforts = np.array([float(j["effort"]) for j in controlled])
            missing = [j["name"] for j in controlled if not j["effort"] > 0]
            if missing:
                raise ConfigError(
                    f"robot.torque_limit=urdf but {self._urdf} gives joint {missing[0]!r} no "
                    "effort limit; give robot.torque_limit as N m (one or per joint) or null"
                )
            return efforts
        if isinstance(setting, str):
            raise ConfigError(
                f"robot.torque_limit={setting!r} must be urdf, a number, one per joint, or null"
            )
        limits = (
            self._per_joint("torque_limit", setting)
            if hasattr(setting, "__len__")
            else np.full(self.num_joints, positive("torque_limit", setting, "robot"))
        )
        if np.any(limits <= 0):
            raise ConfigError(f"robot.torque_limit={setting!r} must be > 0 on every joint")
        return limits

    @property
    def name(self) -> str:
        extras = []
        if self._joint_names is not None:
            extras.append(f"joints {list(self._joint_names)}")
        if self._limit_setting != "urdf":
            extras.append(f"torque limit {self._limit_setting}")
        if self.home is not None:
            extras.append(f"home {self.home.round(6).tolist()}")
        return f"PyBulletArm({', '.join([self._urdf, f'{self.num_joints} joints', *extras])})"

    @property
    def held_joints(self) -> list[str]:
        """Names of the joints held in place (not controlled)."""
        table = {j["index"]: j["name"] for j in self._joint_table()}
        return [table[j] for j in self._held]

    # ------------------------------------------------------------------ simulation
    @staticmethod
    def _floats(values: np.ndarray | Sequence[float]) -> list[float]:
        """PyBullet's dynamics calls can crash the process on numpy arrays: plain floats."""
        return [float(v) for v in np.asarray(values, dtype=np.float64).ravel()]

    def reset(self, positions: np.ndarray, velocities: np.ndarray) -> None:
        pb = self._pb
        for joint, q, qd in zip(
            self._joints, self._floats(positions), self._floats(velocities), strict=True
        ):
            pb.resetJointState(self._body, joint, q, qd, physicsClientId=self._client)
        for joint, q in zip(self._held, self._hold_positions, strict=True):
            pb.resetJointState(self._body, joint, q, 0.0, physicsClientId=self._client)

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """Current ``(q, q̇)`` of the controlled joints."""
        states = self._pb.getJointStates(self._body, self._joints, physicsClientId=self._client)
        return (
            np.array([s[0] for s in states], dtype=np.float64),
            np.array([s[1] for s in states], dtype=np.float64),
        )

    def step(self, torques: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        commanded = np.asarray(torques, dtype=np.float64)
        require_finite(commanded, "the torque", None)
        self._pb.setJointMotorControlArray(
            self._body,
            self._joints,
            self._pb.TORQUE_CONTROL,
            forces=self._floats(self.limited(commanded)),
            physicsClientId=self._client,
        )
        self._pb.stepSimulation(physicsClientId=self._client)
        return self.state()

    def _full(self, values: np.ndarray, held: Sequence[float] | None = None) -> list[float]:
        """Controlled-joint values ``[n]`` → every movable degree of freedom (held ones at
        ``held``, or 0)."""
        full = np.zeros(self._dofs)
        full[self._controlled_dof] = np.asarray(values, dtype=np.float64)
        if held is not None and len(self._held_dof):
            full[self._held_dof] = held
        return self._floats(full)

    def inverse_dynamics(
        self, positions: np.ndarray, velocities: np.ndarray, accelerations: np.ndarray
    ) -> np.ndarray:
        torques = self._pb.calculateInverseDynamics(
            self._body,
            self._full(positions, self._hold_positions),
            self._full(velocities),
            self._full(accelerations),
            physicsClientId=self._client,
        )
        return np.asarray(torques, dtype=np.float64)[self._controlled_dof]

    def mass_matrix(self, positions: np.ndarray) -> np.ndarray:
        matrix = np.asarray(
            self._pb.calculateMassMatrix(
                self._body,
                self._full(positions, self._hold_positions),
                physicsClientId=self._client,
            ),
            dtype=np.float64,
        )
        return matrix[np.ix_(self._controlled_dof, self._controlled_dof)]

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
