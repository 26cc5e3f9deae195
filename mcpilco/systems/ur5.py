"""UR5 joint-space tracking task (thesis §2.6.3): the arm in MuJoCo, an end-effector circle
turned into a joint reference by inverse kinematics, and the poorly tuned PD exploration."""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np

from mcpilco.checks import non_negative, positive
from mcpilco.errors import ConfigError
from mcpilco.policies.exploration import ExplorationController
from mcpilco.systems.base import MechanicalSystem
from mcpilco.systems.mujoco_sim import MujocoSimulation
from mcpilco.systems.ur5_model import dh_forward_kinematics, ur5_mjcf
from mcpilco.trajectory import Trajectory

NOMINAL_POSE = (0.0, -1.2, 1.6, -1.97, -1.57, 0.0)
"""A comfortable elbow-up configuration (rad) that the IK starts from and is pulled toward."""


def flange_position(q: np.ndarray) -> np.ndarray:
    """Tool-flange position ``[3]`` (m, base frame) of joint angles ``q [6]``."""
    return dh_forward_kinematics(q)[:3, 3]


def position_jacobian(q: np.ndarray, step: float = 1e-7) -> np.ndarray:
    """∂ flange position / ∂q ``[3, 6]`` by central differences of the DH chain."""
    columns = []
    for k in range(6):
        shift = np.zeros(6)
        shift[k] = step
        columns.append((flange_position(q + shift) - flange_position(q - shift)) / (2 * step))
    return np.stack(columns, axis=1)


def inverse_kinematics(
    target: np.ndarray,
    start: np.ndarray,
    nominal: np.ndarray,
    iterations: int = 200,
    tolerance: float = 1e-8,
    damping: float = 1e-6,
    pull: float = 1e-3,
) -> np.ndarray:
    """Joint angles ``[6]`` whose flange is at ``target [3]``: damped least squares from
    ``start``, with the redundant directions pulled gently toward ``nominal``."""
    q = np.array(start, dtype=np.float64)
    for _ in range(iterations):
        error = target - flange_position(q)
        if float(error @ error) < tolerance**2:
            break
        jacobian = position_jacobian(q)
        inverse = jacobian.T @ np.linalg.inv(jacobian @ jacobian.T + damping * np.eye(3))
        null = np.eye(6) - inverse @ jacobian
        step = inverse @ error + pull * null @ (nominal - q)
        q = q + step * min(1.0, 0.2 / max(float(np.linalg.norm(step)), 1e-12))  # ≤ 0.2 rad
    if float(np.linalg.norm(target - flange_position(q))) > 1e-6:
        raise ConfigError(f"system: the circle point {target.tolist()} is out of the UR5's reach")
    return q


@functools.lru_cache(maxsize=16)
def _solve_path(points: tuple[tuple[float, ...], ...], nominal: tuple[float, ...]) -> np.ndarray:
    """IK of every point along a path, each solve starting from the previous solution;
    ``[len(points), 6]``, read-only (cached: every build of the same task reuses it)."""
    nominal_q = np.asarray(nominal, dtype=np.float64)
    q, positions = nominal_q, []
    for point in points:
        q = inverse_kinematics(np.asarray(point), q, nominal_q)
        positions.append(q)
    solved = np.array(positions)
    solved.setflags(write=False)
    return solved


class CircleReference:
    """The flange drawing a circle in a horizontal (X-Y) plane once per trial, and its
    joint-space reference by inverse kinematics.

    Args:
        centre: circle centre (m, base frame) ``[3]``. radius: m.
        duration: time for one turn (s). dt: sampling time (s).
        nominal: joint angles the IK starts from (rad).
    """

    def __init__(
        self,
        centre: Sequence[float],
        radius: float,
        duration: float,
        dt: float,
        nominal: Sequence[float] = NOMINAL_POSE,
    ) -> None:
        if radius <= 0:
            raise ConfigError(f"system.circle_radius must be > 0, got {radius}")
        self.centre = np.asarray(centre, dtype=np.float64)
        self.radius, self.duration, self.dt = float(radius), float(duration), float(dt)
        steps = int(round(duration / dt))
        angles = 2 * np.pi * np.arange(steps + 1) * dt / duration
        self.points = self.centre + radius * np.stack(
            [np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=-1
        )  # [T+1, 3]
        self.positions = _solve_path(
            tuple(map(tuple, self.points.tolist())), tuple(float(x) for x in nominal)
        )  # [T+1, 6], read-only
        # central differences inside, second-order one-sided ones at the ends (the joints
        # need not close the loop exactly: the arm is redundant for a position task)
        self.velocities = np.gradient(self.positions, dt, axis=0, edge_order=2)  # [T+1, 6]

    @property
    def states(self) -> np.ndarray:
        """``[q_ref, q̇_ref]`` per sample, ``[T+1, 12]``."""
        return np.concatenate([self.positions, self.velocities], axis=-1)


class UR5(MechanicalSystem):
    """The UR5 in MuJoCo (:func:`~mcpilco.systems.ur5_model.ur5_mjcf`) tracking a circle:
    state ``[q, q̇]`` (rad, rad/s, 12), action the six motor controls (|u| ≤ u_max).

    The action is each motor's control, the joint torque ``gear`` times it. With
    ``gravity_compensation`` (the class default) the simulation runs without gravity, i.e.
    with a perfect gravity compensation under the learned torques: with gear 1 the thesis's
    u_max of 1 per joint could not hold the arm up. The config (``conf/system/ur5.yaml``)
    follows the public reference code's UR5 model instead: gear 101 (so |τ| ≤ 101 N m),
    joint damping 65 N m s/rad on the three large joints and 45 on the wrists, armature
    0.01 kg m², gravity on. p(x0) is centred on the reference's first state.

    Args:
        circle_centre, circle_radius: the flange's circle (m). timestep: MuJoCo's step (s).
        joint_damping: N m s/rad, one value or one per joint. gear: joint torque per unit
            of action (N m). armature: rotor inertia added to each joint (kg m²).
        integrator: MuJoCo's integrator; heavy joint damping needs one that treats it
            implicitly (``IMPLICITFAST``: RK4 diverges at damping 65 with armature 0.01).
        success_error_mm: mean flange error that counts as a
            success. Others: see :class:`MechanicalSystem` (the thesis: T_s 0.02 s, 4 s,
            noise std 1e-3, x0 std 1e-3).
    """

    position_indices = (0, 1, 2, 3, 4, 5)
    velocity_indices = (6, 7, 8, 9, 10, 11)
    angle_indices = (0, 1, 2, 3, 4, 5)
    action_dim = 6
    state_names = tuple(f"q{k + 1} [rad]" for k in range(6)) + tuple(
        f"q̇{k + 1} [rad/s]" for k in range(6)
    )

    def __init__(
        self,
        dt: float = 0.02,
        trial_duration: float = 4.0,
        u_max: float = 1.0,
        measurement_noise_std: float | Sequence[float] = 1e-3,
        initial_std: float | Sequence[float] = 1e-3,
        measured_indices: Sequence[int] | None = None,
        quantization: float | Sequence[float] | None = None,
        circle_centre: Sequence[float] = (-0.5, -0.1, 0.3),
        circle_radius: float = 0.1,
        gravity_compensation: bool = True,
        joint_damping: float | Sequence[float] = 0.0,
        gear: float = 1.0,
        armature: float = 0.0,
        integrator: str = "RK4",
        timestep: float = 1e-3,
        success_error_mm: float = 2.0,
    ) -> None:
        self.reference = CircleReference(circle_centre, circle_radius, trial_duration, dt)
        super().__init__(
            dt,
            trial_duration,
            u_max,
            measurement_noise_std,
            self.reference.states[0],
            initial_std,
            measured_indices,
            quantization,
        )
        non_negative("joint_damping", joint_damping)
        non_negative("armature", armature)
        gear = positive("gear", gear)
        positive("timestep", timestep)
        self.success_error_mm = positive("success_error_mm", success_error_mm)
        xml = ur5_mjcf(damping=joint_damping, torque_limit=u_max, gear=gear, armature=armature)
        if gravity_compensation:
            xml = xml.replace('gravity="0 0 -9.81"', 'gravity="0 0 0"')
        self.simulation = MujocoSimulation(xml, dt, timestep=timestep, integrator=integrator)

    @property
    def reference_states(self) -> np.ndarray:  # type: ignore[override]
        """``[q_ref, q̇_ref]`` per sample ``[T+1, 12]``: a tracking task."""
        return self.reference.states

    def step(self, state: np.ndarray, action: np.ndarray) -> np.ndarray:
        positions, velocities = self.simulation.step(state[:6], state[6:], action)
        return np.concatenate([positions, velocities])

    def flange_errors_mm(self, states: np.ndarray) -> np.ndarray:
        """Distance of the flange from the circle's point at each sample ``[T+1]`` (mm)."""
        reached = np.array([flange_position(q) for q in states[:, :6]])
        points = self.reference.points[: states.shape[0]]
        return 1000.0 * np.linalg.norm(reached - points, axis=-1)

    def evaluate(self, trajectory: Trajectory) -> dict[str, float]:
        """Fig. 2.12's metrics: mean ± std and max flange error (mm); success when the mean
        is at most ``success_error_mm``."""
        errors = self.flange_errors_mm(trajectory.states)
        return {
            "mean_error_mm": float(errors.mean()),
            "std_error_mm": float(errors.std()),
            "max_error_mm": float(errors.max()),
            "success": bool(errors.mean() <= self.success_error_mm),
        }


class PDExploration(ExplorationController):
    """τ = K_P (q_ref − q) + K_D (q̇_ref − q̇) on the measurement, clipped to ±u_max — the
    thesis's "poorly tuned" PD exploration of the UR5 (gains are per joint or one for all).
    Where only the joint angles are read (DF, §4.3), q̇ is their backward difference.

    Args:
        u_max: torque bound. action_dim: number of joints. rng: draws the gains when ranges
            are given (the system's stream: the seed decides them).
        system: a tracking task (its ``reference_states`` ``[T+1, 2 d_u]``) read as
            ``[q, q̇]`` or ``[q]``.
        kp: N m/rad. kd: N m s/rad.
        kp_range, kd_range: ``[low, high]``: draw one K_P ~ U(low, high) and one K_D for all
            joints instead (§4.3: U(0.5, 2) and U(0.01, 0.2), new gains per repetition).
    """

    def __init__(
        self,
        u_max: float,
        action_dim: int,
        rng: np.random.Generator,
        system: MechanicalSystem,
        kp: float | Sequence[float] = 1.0,
        kd: float | Sequence[float] = 0.1,
        kp_range: Sequence[float] | None = None,
        kd_range: Sequence[float] | None = None,
    ) -> None:
        if system.reference_states is None:
            raise ConfigError(f"exploration=pd needs a tracking task, not {type(system).__name__}")
        for name, bounds in (("kp_range", kp_range), ("kd_range", kd_range)):
            if bounds is not None and not (len(bounds) == 2 and 0 <= bounds[0] <= bounds[1]):
                raise ConfigError(f"exploration.{name} must be [low, high], got {bounds!r}")
        if kp_range is not None:
            kp = float(rng.uniform(*kp_range))
        if kd_range is not None:
            kd = float(rng.uniform(*kd_range))
        self.u_max, self.reference = u_max, np.asarray(system.reference_states)
        self.kp = np.broadcast_to(np.asarray(kp, dtype=np.float64), (action_dim,))
        self.kd = np.broadcast_to(np.asarray(kd, dtype=np.float64), (action_dim,))
        self.dt = system.dt
        self._previous: np.ndarray | None = None

    def __call__(self, measurement: np.ndarray, step: int) -> np.ndarray:
        target = self.reference[min(step, self.reference.shape[0] - 1)]
        joints = self.kp.shape[0]
        angles = measurement[:joints]
        if measurement.shape[0] >= 2 * joints:
            velocities = measurement[joints : 2 * joints]
        else:  # angles only: backward differences (zero at the first sample)
            previous = angles if step == 0 or self._previous is None else self._previous
            velocities = (angles - previous) / self.dt
        self._previous = angles.copy()
        torque = self.kp * (target[:joints] - angles) + self.kd * (target[joints:] - velocities)
        return np.clip(torque, -self.u_max, self.u_max)
