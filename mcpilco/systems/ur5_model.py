"""An MJCF model of the UR5 arm written from its published DH and inertial parameters.

Kinematics: Universal Robots' standard DH table for the UR5 (d1 0.089159, a2 −0.425,
a3 −0.39225, d4 0.10915, d5 0.09465, d6 0.0823 m; α = π/2, 0, 0, π/2, −π/2, 0). Link masses
(3.7, 8.393, 2.275, 1.219, 1.219, 0.1879 kg) and centres of mass (in each link's DH frame)
from the same publication; link inertias are those of uniform cylinders of the link's
length (no meshes). Each MuJoCo body i is DH frame i−1, its hinge turns about the body's
z axis, and body i+1 sits at ``Tz(d_i) Tx(a_i) Rx(α_i)`` — so MuJoCo's forward kinematics
is the DH chain by construction, which the tests check against the DH product.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mcpilco.errors import ConfigError

DH_D = (0.089159, 0.0, 0.0, 0.10915, 0.09465, 0.0823)
DH_A = (0.0, -0.425, -0.39225, 0.0, 0.0, 0.0)
DH_ALPHA = (np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0)
MASSES = (3.7, 8.393, 2.275, 1.219, 1.219, 0.1879)
CENTRES_OF_MASS = (  # in DH frame i (after joint i's transform), metres
    (0.0, -0.02561, 0.00193),
    (0.2125, 0.0, 0.11336),
    (0.15, 0.0, 0.0265),
    (0.0, -0.0018, 0.01634),
    (0.0, 0.0018, 0.01634),
    (0.0, 0.0, -0.001159),
)
LINK_RADIUS = 0.05  # m, for the cylinder inertias


def dh_transform(theta: float, d: float, a: float, alpha: float) -> np.ndarray:
    """Standard DH: Rz(θ) Tz(d) Tx(a) Rx(α), ``[4, 4]``."""
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    return np.array(
        [
            [ct, -st * ca, st * sa, a * ct],
            [st, ct * ca, -ct * sa, a * st],
            [0.0, sa, ca, d],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def dh_forward_kinematics(q: np.ndarray) -> np.ndarray:
    """Tool-flange pose ``[4, 4]`` in the base frame for joint angles ``q [6]``."""
    pose = np.eye(4)
    for angle, d, a, alpha in zip(q, DH_D, DH_A, DH_ALPHA, strict=True):
        pose = pose @ dh_transform(angle, d, a, alpha)
    return pose


def _quat_x(angle: float) -> str:
    return f"{np.cos(angle / 2):.12g} {np.sin(angle / 2):.12g} 0 0"


def _cylinder_inertia(mass: float, length: float) -> str:
    """Diagonal inertia of a uniform cylinder along z (kg m²), as MJCF text."""
    length = max(length, 0.05)
    side = mass * (3 * LINK_RADIUS**2 + length**2) / 12
    axial = mass * LINK_RADIUS**2 / 2
    return f"{side:.6g} {side:.6g} {axial:.6g}"


def ur5_mjcf(
    damping: float | Sequence[float] = 0.0,
    torque_limit: float = 150.0,
    gear: float = 1.0,
    armature: float = 0.0,
) -> str:
    """The UR5 as MJCF: six hinges with torque motors (joint torque = ``gear`` × control,
    control within ±``torque_limit``), joint damping ``damping`` (N m s/rad, one value or
    one per joint), rotor inertia ``armature`` (kg m²) on every joint, a ``flange`` site at
    the tool flange, no collisions (the task is free-space tracking)."""
    dampings = [float(damping)] * 6 if isinstance(damping, (int, float)) else list(damping)
    if len(dampings) != 6 or min(dampings) < 0:
        raise ConfigError(f"system.joint_damping must be >= 0, one or six values: {damping!r}")
    if gear <= 0 or armature < 0:
        raise ConfigError(f"system.gear must be > 0 and system.armature >= 0: {gear}, {armature}")
    body = '<site name="flange" pos="0 0 0" size="0.01"/>'
    for i in reversed(range(6)):
        d, a, alpha = DH_D[i], DH_A[i], DH_ALPHA[i]
        # Inertial frame: the COM is given in frame i, which is this body's frame moved by
        # Tz(d) Tx(a) Rx(α); express it in this body's (rotating) frame.
        local = dh_transform(0.0, d, a, alpha) @ np.array([*CENTRES_OF_MASS[i], 1.0])
        length = float(np.hypot(a, d))
        body = (
            f'<body name="link{i + 1}">'
            f'<joint name="joint{i + 1}" type="hinge" axis="0 0 1" damping="{dampings[i]}" '
            f'armature="{armature}"/>'
            f'<inertial pos="{local[0]:.6g} {local[1]:.6g} {local[2]:.6g}" '
            f'mass="{MASSES[i]}" diaginertia="{_cylinder_inertia(MASSES[i], length)}"/>'
            f'<body name="frame{i + 1}" pos="{a} 0 {d}" quat="{_quat_x(alpha)}">{body}</body>'
            "</body>"
        )
    motors = "".join(
        f'<motor joint="joint{i + 1}" gear="{gear}" ctrllimited="true" '
        f'ctrlrange="-{torque_limit} {torque_limit}"/>'
        for i in range(6)
    )
    return (
        '<mujoco model="ur5"><option gravity="0 0 -9.81"/>'
        f"<worldbody>{body}</worldbody><actuator>{motors}</actuator></mujoco>"
    )
