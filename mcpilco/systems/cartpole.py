"""Cart-pole swing-up (thesis §2.5, App. A.1; PILCO's physical parameters)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import torch

from mcpilco.checks import non_negative, positive
from mcpilco.systems.base import OdeSystem
from mcpilco.trajectory import Trajectory


class CartPole(OdeSystem):
    """Cart on a track with a pendulum; state ``[p, ṗ, θ, θ̇]`` (m, m/s, rad, rad/s).

    θ = 0 hangs down, θ = ±π is upright. The input is the horizontal force on the cart (N).

    Args:
        cart_mass: M in kg. pole_mass: m in kg. pole_length: L in m.
        friction: viscous cart friction b in N·s/m. gravity: g in m/s².
        success_position: |p| bound (m) and ``success_angle_deg`` the allowed deviation of
            |θ| from 180° (deg), both over the last ``success_window`` seconds.
        eval_length_scale: length-scale (m) of the evaluation cost (2.17).
        Others: see :class:`MechanicalSystem`.
    """

    position_indices = (0, 2)
    velocity_indices = (1, 3)
    angle_indices = (2,)
    action_dim = 1
    state_names = ("p [m]", "ṗ [m/s]", "θ [rad]", "θ̇ [rad/s]")

    def __init__(
        self,
        dt: float = 0.05,
        trial_duration: float = 3.0,
        u_max: float = 10.0,
        measurement_noise_std: float | Sequence[float] = 1e-2,
        initial_mean: Sequence[float] = (0.0, 0.0, 0.0, 0.0),
        initial_std: float | Sequence[float] = 1e-2,
        cart_mass: float = 0.5,
        pole_mass: float = 0.5,
        pole_length: float = 0.5,
        friction: float = 0.1,
        gravity: float = 9.81,
        success_position: float = 0.1,
        success_angle_deg: float = 10.0,
        success_window: float = 1.0,
        eval_length_scale: float = 0.25,
        measured_indices: Sequence[int] | None = None,
        quantization: float | Sequence[float] | None = None,
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
        self.cart_mass = positive("cart_mass", cart_mass)
        self.pole_mass = positive("pole_mass", pole_mass)
        self.pole_length = positive("pole_length", pole_length)
        self.friction = non_negative("friction", friction)
        self.gravity = non_negative("gravity", gravity)
        self.success_position = positive("success_position", success_position)
        self.success_angle_deg = positive("success_angle_deg", success_angle_deg)
        self.success_window = positive("success_window", success_window)
        self.eval_length_scale = positive("eval_length_scale", eval_length_scale)

    def accelerations(
        self,
        cart_velocity: Any,
        angle: Any,
        angular_velocity: Any,
        force: Any,
        sin: Callable[[Any], Any],
        cos: Callable[[Any], Any],
    ) -> tuple[Any, Any]:
        """(p̈ in m/s², θ̈ in rad/s²) of App. A.1 (Lagrangian, pole as a uniform rod) for
        numpy or torch arrays of matching shape: one formula for :meth:`derivatives` and
        :meth:`torch_derivatives`."""
        force = force - self.friction * cart_velocity
        big_m, m, length, g = self.cart_mass, self.pole_mass, self.pole_length, self.gravity
        s, c = sin(angle), cos(angle)
        denominator = 4.0 * (big_m + m) - 3.0 * m * c**2
        p_ddot = (
            2.0 * m * length * angular_velocity**2 * s + 3.0 * m * g * s * c + 4.0 * force
        ) / denominator
        theta_ddot = (
            -3.0 * m * length * angular_velocity**2 * s * c
            - 6.0 * (big_m + m) * g * s
            - 6.0 * force * c
        ) / (length * denominator)
        return p_ddot, theta_ddot

    def derivatives(self, state: np.ndarray, action: np.ndarray) -> np.ndarray:
        """Equations of motion of App. A.1."""
        _, p_dot, theta, theta_dot = state
        p_ddot, theta_ddot = self.accelerations(
            p_dot, theta, theta_dot, float(action[0]), np.sin, np.cos
        )
        return np.array([p_dot, p_ddot, theta_dot, theta_ddot])

    def torch_derivatives(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """ẋ ``[..., 4]`` of states ``[..., 4]`` under forces ``[..., 1]``, differentiable."""
        p_dot, theta, theta_dot = states[..., 1], states[..., 2], states[..., 3]
        p_ddot, theta_ddot = self.accelerations(
            p_dot, theta, theta_dot, actions[..., 0], torch.sin, torch.cos
        )
        return torch.stack([p_dot, p_ddot, theta_dot, theta_ddot], dim=-1)

    def energy(self, state: np.ndarray) -> float:
        """Total mechanical energy (J), potential zero at the pivot height."""
        _, p_dot, theta, theta_dot = state
        m, length = self.pole_mass, self.pole_length
        kinetic = (
            0.5 * (self.cart_mass + m) * p_dot**2
            + 0.5 * m * length * p_dot * theta_dot * np.cos(theta)
            + m * length**2 * theta_dot**2 / 6.0
        )
        potential = -0.5 * m * self.gravity * length * np.cos(theta)
        return float(kinetic + potential)

    def velocity_basis(self, features: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        """φ_ṗ = [θ̇² sinθ, sinθ cosθ, u, ṗ], φ_θ̇ = [θ̇² sinθ cosθ, sinθ, u cosθ, ṗ cosθ];
        features x* = [p, ṗ, θ̇, sin θ, cos θ]."""
        p_dot, theta_dot, s, c = (
            features[..., 1],
            features[..., 2],
            features[..., 3],
            features[..., 4],
        )
        u = action[..., 0]
        w2s = theta_dot.square() * s
        phi_cart = torch.stack([w2s, s * c, u, p_dot], dim=-1)
        phi_pole = torch.stack([w2s * c, s, u * c, p_dot * c], dim=-1)
        return torch.stack([phi_cart, phi_pole], dim=0)

    def sketch(self, states: np.ndarray) -> np.ndarray:
        """Cart (a 0.2 m bar on the track) and pole (pivot to tip), ``[T+1, 2, 2, 2]``."""
        p, theta = states[:, 0], states[:, 2]
        zeros = np.zeros_like(p)
        tip = np.stack(
            [p + self.pole_length * np.sin(theta), -self.pole_length * np.cos(theta)], -1
        )
        cart = np.stack([np.stack([p - 0.1, zeros], -1), np.stack([p + 0.1, zeros], -1)], 1)
        pole = np.stack([np.stack([p, zeros], -1), tip], 1)
        return np.stack([cart, pole], 1)

    def evaluation_cost(self, states: np.ndarray) -> np.ndarray:
        """PILCO's cost (2.17) per state ``[T+1]``: 1 − exp(−½ (d/0.25)²)."""
        p, theta = states[:, 0], states[:, 2]
        length = self.pole_length
        d2 = p**2 + 2.0 * p * length * np.sin(theta) + 2.0 * length**2 * (1.0 + np.cos(theta))
        return 1.0 - np.exp(-0.5 * d2 / self.eval_length_scale**2)

    def evaluate(self, trajectory: Trajectory) -> dict[str, float]:
        """Cumulative evaluation cost over x_0..x_T, success (§2.5) and final precision."""
        states = trajectory.states
        window = trajectory.times >= trajectory.times[-1] - self.success_window - 1e-9
        p, abs_theta_deg = states[window, 0], np.degrees(np.abs(states[window, 2]))
        success = bool(
            np.all(np.abs(p) < self.success_position)
            and np.all(np.abs(abs_theta_deg - 180.0) < self.success_angle_deg)
        )
        return {
            "eval_cost": float(self.evaluation_cost(states).sum()),
            "success": success,
            "final_position_error": float(np.mean(np.abs(p))),
            "final_angle_error": float(np.mean(np.abs(np.abs(states[window, 2]) - np.pi))),
        }
