"""Furuta (rotary inverted) pendulum driven by a DC motor (thesis §3.4.1, §4.4.1)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import torch

from mcpilco.checks import non_negative, positive
from mcpilco.systems.base import OdeSystem
from mcpilco.trajectory import Trajectory

BARRIER = 0.75 * np.pi
"""|θh| beyond which the cost's barrier term penalises the arm (eq. 3.2)."""


def furuta_cost(states: np.ndarray) -> np.ndarray:
    """Eq. 3.2 per state ``[..., 4]``: 1 − exp(−(θh/2)² − ((|θv|−π)/2)²) + c_b(θh)."""
    arm, pendulum = states[..., 0], states[..., 2]
    shaped = 1.0 - np.exp(-((arm / 2) ** 2) - ((np.abs(pendulum) - np.pi) / 2) ** 2)
    barrier = 1 / (1 + np.exp(-10 * (-BARRIER - arm))) + 1 / (1 + np.exp(-10 * (arm - BARRIER)))
    return shaped + barrier


class FurutaPendulum(OdeSystem):
    """Rotary arm (θh, about the vertical) carrying a pendulum (θv, 0 hanging down, ±π up);
    state ``[θh, θ̇h, θv, θ̇v]`` (rad, rad/s), input the motor voltage (V).

    Both links are uniform rods. Lagrangian dynamics (derived here) with
    ``M(θv) [θ̈h, θ̈v]ᵀ + c(θ, θ̇) + g(θv) = [τ − D_h θ̇h, −D_v θ̇v]ᵀ``, where
    ``M = [[J_h + m_p L_h² + J_v sin²θv, m_p L_h l cos θv], [m_p L_h l cos θv, J_v]]``,
    J_h = m_h L_h²/3 + hub/rotor inertia, J_v = m_p L_v²/3, l = L_v/2, and the motor torque
    τ = k_t (V − k_m θ̇h) / R_m. Defaults: the Quanser QUBE-Servo 2 data sheet (R_m 8.4 Ω,
    k_t = k_m = 0.042, arm 0.095 kg × 0.085 m, pendulum 0.024 kg × 0.129 m, rotor 4e-6 kg m²,
    hub 0.6e-6 kg m²) with the lighter damping of public QUBE-Servo 2 simulators (D_h 2.7e-4,
    D_v 5e-5 N m s/rad). Quanser's course material quotes 1.5e-3 and 5e-4, approximate; with
    those, full-voltage energy pumping never lifts the pendulum above ~1.8 rad in 10 s
    (tested) and open-loop trajectory optimisation over 3 s reached 1.74 rad (measured), so
    the thesis's 3 s swing-up would be impossible.

    Args:
        arm_mass, arm_length, pendulum_mass, pendulum_length: kg, m.
        rotor_inertia: motor rotor + hub inertia about the arm axis (kg m²).
        arm_damping, pendulum_damping: viscous damping (N m s/rad).
        resistance, torque_constant, back_emf_constant: R_m (Ω), k_t (N m/A), k_m (V s/rad).
        gravity: m/s². success_window: seconds at the end of a trial for :meth:`evaluate`.
        success_angle_deg: allowed deviation of |θv| from 180° over that window.
        Others: see :class:`MechanicalSystem` (the thesis: 30 Hz, 3 s, x0 ~ N(0, 5e-3 I),
        4096-count encoders).
    """

    position_indices = (0, 2)
    velocity_indices = (1, 3)
    angle_indices = (0, 2)
    action_dim = 1
    state_names = ("θh [rad]", "θ̇h [rad/s]", "θv [rad]", "θ̇v [rad/s]")

    def __init__(
        self,
        dt: float = 1.0 / 30.0,
        trial_duration: float = 3.0,
        u_max: float = 10.0,
        measurement_noise_std: float | Sequence[float] = 1e-4,
        initial_mean: Sequence[float] = (0.0, 0.0, 0.0, 0.0),
        initial_std: float | Sequence[float] = float(np.sqrt(5e-3)),
        measured_indices: Sequence[int] | None = None,
        quantization: float | Sequence[float] | None = None,
        arm_mass: float = 0.095,
        arm_length: float = 0.085,
        pendulum_mass: float = 0.024,
        pendulum_length: float = 0.129,
        rotor_inertia: float = 4.6e-6,
        arm_damping: float = 2.7e-4,
        pendulum_damping: float = 5e-5,
        resistance: float = 8.4,
        torque_constant: float = 0.042,
        back_emf_constant: float = 0.042,
        gravity: float = 9.81,
        success_window: float = 1.0,
        success_angle_deg: float = 10.0,
    ) -> None:
        super().__init__(
            dt,
            trial_duration,
            u_max,
            measurement_noise_std,
            initial_mean,
            initial_std,
            measured_indices,
            quantization,
        )
        arm_mass, arm_length = positive("arm_mass", arm_mass), positive("arm_length", arm_length)
        pendulum_mass = positive("pendulum_mass", pendulum_mass)
        pendulum_length = positive("pendulum_length", pendulum_length)
        rotor_inertia = non_negative("rotor_inertia", rotor_inertia)
        arm_damping = non_negative("arm_damping", arm_damping)
        pendulum_damping = non_negative("pendulum_damping", pendulum_damping)
        resistance = positive("resistance", resistance)
        torque_constant = positive("torque_constant", torque_constant)
        back_emf_constant = non_negative("back_emf_constant", back_emf_constant)
        gravity = non_negative("gravity", gravity)
        success_window = positive("success_window", success_window)
        success_angle_deg = positive("success_angle_deg", success_angle_deg)
        self.arm_inertia = arm_mass * arm_length**2 / 3 + rotor_inertia  # J_h
        self.pendulum_inertia = pendulum_mass * pendulum_length**2 / 3  # J_v about the pivot
        self.arm_length = arm_length
        self.pendulum_mass = pendulum_mass
        self.pendulum_length = pendulum_length
        self.arm_damping, self.pendulum_damping = arm_damping, pendulum_damping
        self.resistance = resistance
        self.torque_constant, self.back_emf_constant = torque_constant, back_emf_constant
        self.gravity = gravity
        self.success_window = success_window
        self.success_angle_deg = success_angle_deg

    def motor_torque(self, voltage: Any, arm_velocity: Any) -> Any:
        """τ = k_t (V − k_m θ̇h) / R_m (N m; armature inductance neglected)."""
        return (
            self.torque_constant
            * (voltage - self.back_emf_constant * arm_velocity)
            / (self.resistance)
        )

    def accelerations(
        self,
        arm_velocity: Any,
        angle: Any,
        velocity: Any,
        voltage: Any,
        sin: Callable[[Any], Any],
        cos: Callable[[Any], Any],
    ) -> tuple[Any, Any]:
        """(θ̈h, θ̈v) in rad/s² from θ̇h, θv, θ̇v and the voltage, for numpy or torch arrays
        of any (matching) shape: the 2×2 mass matrix is inverted in closed form, so one
        formula serves :meth:`derivatives` and :meth:`torch_derivatives`."""
        torque = self.motor_torque(voltage, arm_velocity)
        s, c = sin(angle), cos(angle)
        coupling = self.pendulum_mass * self.arm_length * self.pendulum_length / 2  # m_p L_h l
        j_v = self.pendulum_inertia
        arm_mass_term = self.arm_inertia + self.pendulum_mass * self.arm_length**2 + j_v * s * s
        off_diagonal = coupling * c
        gravity_torque = self.pendulum_mass * self.gravity * self.pendulum_length / 2 * s
        arm_force = (
            torque
            - self.arm_damping * arm_velocity
            - 2 * j_v * s * c * arm_velocity * velocity
            + coupling * s * velocity**2
        )
        force = -self.pendulum_damping * velocity + j_v * s * c * arm_velocity**2 - gravity_torque
        determinant = arm_mass_term * j_v - off_diagonal**2
        arm_acceleration = (j_v * arm_force - off_diagonal * force) / determinant
        acceleration = (arm_mass_term * force - off_diagonal * arm_force) / determinant
        return arm_acceleration, acceleration

    def derivatives(self, state: np.ndarray, action: np.ndarray) -> np.ndarray:
        _, arm_velocity, angle, velocity = state
        arm_acceleration, acceleration = self.accelerations(
            arm_velocity, angle, velocity, float(action[0]), np.sin, np.cos
        )
        return np.array([arm_velocity, arm_acceleration, velocity, acceleration])

    def torch_derivatives(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """ẋ ``[..., 4]`` of states ``[..., 4]`` under voltages ``[..., 1]``, differentiable."""
        arm_velocity, angle, velocity = states[..., 1], states[..., 2], states[..., 3]
        arm_acceleration, acceleration = self.accelerations(
            arm_velocity, angle, velocity, actions[..., 0], torch.sin, torch.cos
        )
        return torch.stack([arm_velocity, arm_acceleration, velocity, acceleration], dim=-1)

    def energy(self, state: np.ndarray) -> float:
        """Kinetic + potential energy (J), zero potential with the pendulum at the pivot."""
        _, arm_velocity, angle, velocity = state
        s, c = np.sin(angle), np.cos(angle)
        m, lh, l_half = self.pendulum_mass, self.arm_length, self.pendulum_length / 2
        kinetic = 0.5 * (
            (self.arm_inertia + m * lh**2 + self.pendulum_inertia * s * s) * arm_velocity**2
            + 2 * m * lh * l_half * c * arm_velocity * velocity
            + self.pendulum_inertia * velocity**2
        )
        return float(kinetic - m * self.gravity * l_half * c)

    def velocity_basis(self, features: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        """§3.4.1: φ_θ̇h = [θ̇v² sin θv, θ̇h θ̇v sin 2θv, θ̇h, u],
        φ_θ̇v = [θ̇h² sin 2θv, θ̇v, sin θv, u cos θv]; features
        x* = [θ̇h, θ̇v, sin θh, sin θv, cos θh, cos θv]."""
        arm_velocity, velocity = features[..., 0], features[..., 1]
        s, c = features[..., 3], features[..., 5]
        u = action[..., 0]
        sin_double = 2 * s * c
        phi_arm = torch.stack(
            [velocity.square() * s, arm_velocity * velocity * sin_double, arm_velocity, u], -1
        )
        phi_pendulum = torch.stack([arm_velocity.square() * sin_double, velocity, s, u * c], dim=-1)
        return torch.stack([phi_arm, phi_pendulum], dim=0)

    def evaluation_cost(self, states: np.ndarray) -> np.ndarray:
        """The training cost (3.2) per state ``[T+1]``."""
        return furuta_cost(states)

    def evaluate(self, trajectory: Trajectory) -> dict[str, float]:
        """Cumulative cost (3.2); success: the pendulum within ``success_angle_deg`` of
        upright and the arm inside the ±¾π barrier over the last ``success_window`` s."""
        states = trajectory.states
        window = trajectory.times >= trajectory.times[-1] - self.success_window - 1e-9
        upright = np.abs(np.degrees(np.abs(states[window, 2])) - 180.0) < self.success_angle_deg
        inside = np.abs(states[window, 0]) < BARRIER
        return {
            "eval_cost": float(furuta_cost(states).sum()),
            "success": bool(np.all(upright) and np.all(inside)),
            "final_arm_error": float(np.mean(np.abs(states[window, 0]))),
            "final_angle_error": float(np.mean(np.abs(np.abs(states[window, 2]) - np.pi))),
        }

    def sketch(self, states: np.ndarray) -> np.ndarray:
        """Side view along the arm's tangent: the pendulum from its pivot, ``[T+1, 1, 2, 2]``
        (the arm angle shows as the pivot's horizontal position θh · L_h)."""
        pivot_x = states[:, 0] * self.arm_length
        zeros = np.zeros_like(pivot_x)
        tip = np.stack(
            [
                pivot_x + self.pendulum_length * np.sin(states[:, 2]),
                -self.pendulum_length * np.cos(states[:, 2]),
            ],
            -1,
        )
        return np.stack([np.stack([pivot_x, zeros], -1), tip], 1)[:, None]
