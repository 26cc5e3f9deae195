"""Ball-and-plate: a ball rolling on a plate tilted by two position-controlled motors
(thesis §3.4.2, §4.4.2; a real rig in the thesis, simulated here)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch

from mcpilco.checks import non_negative, positive
from mcpilco.errors import ConfigError
from mcpilco.systems.base import Controller, OdeSystem
from mcpilco.trajectory import Trajectory

ROLLING = 5.0 / 7.0
"""m r² / (m r² + I) for a solid sphere (I = 2/5 m r²): its share of the tilt force."""


def ball_and_plate_cost(states: np.ndarray) -> np.ndarray:
    """Eq. 3.3 per state ``[..., 8]``: 1 − exp(−(bx/0.15)² − (by/0.15)² − θ1² − θ2²)."""
    ball = states[..., 0:2] / 0.15
    angles = states[..., 4:6]
    return 1.0 - np.exp(-np.sum(ball**2, -1) - np.sum(angles**2, -1))


class BallAndPlate(OdeSystem):
    """State ``[bx, by, ḃx, ḃy, θ1, θ2, θ̇1, θ̇2]`` (m, m/s, rad, rad/s): the ball's centre on
    the plate and the two motor angles; the action ``[u1, u2]`` is the change of each motor's
    reference angle over one step (rad, |u| ≤ u_max = 4°).

    Motors: position-controlled drives reach the new reference within the step, modelled as a
    constant motor speed u/T_s over the step (so θ_{t+1} = θ_t + u_t exactly and θ̇_t is the
    last step's speed — the causal difference the thesis feeds its GPs). The plate tilts by
    ``linkage_ratio`` times the motor angles (α = r θ) about two orthogonal axes through its
    centre. Ball: a solid sphere rolling without slipping, Lagrangian equations for a plate
    rotating about axes through the ball's plane (ball height above the axes neglected):

        b̈x = 5/7 (bx α̇1² + by α̇1 α̇2 − g sin α1) − (c/m) ḃx, likewise for y (α2),

    so a still plate tilted by α accelerates a ball at rest by (5/7) g sin α (tested). The
    thesis keeps a rollout's data only up to the ball's collision with the plate's border:
    :meth:`rollout` cuts the trajectory at the first sample where the ball's edge passes
    ``plate_half_width``.

    Args:
        plate_half_width: half the side of the square plate (m; the thesis: about 0.20 m
            square). ball_radius: m (the thesis: 0.016). linkage_ratio: plate tilt per motor
            angle (the rig's value is not published; 1 = direct drive). rolling_friction:
            c/m (1/s). gravity: m/s². success_radius: final distance from the centre that
            counts as a success (default: the ball's radius). success_window: seconds at
            the end of the trial over which the distance is averaged.
        Others: see :class:`MechanicalSystem`. p(x0) is uniform (``initial_distribution``):
        ``initial_std`` is the half-width per component; the default puts the ball anywhere
        on the plate and the motors within ±1e-6 rad of level.
    """

    position_indices = (0, 1, 4, 5)
    velocity_indices = (2, 3, 6, 7)
    angle_indices = (4, 5)
    action_dim = 2
    known_coordinates = (2, 3)  # the motors: θ_{t+1} = θ_t + u_t, θ̇_{t+1} = u_t / T_s
    state_names = (
        "bx [m]",
        "by [m]",
        "ḃx [m/s]",
        "ḃy [m/s]",
        "θ1 [rad]",
        "θ2 [rad]",
        "θ̇1 [rad/s]",
        "θ̇2 [rad/s]",
    )

    def __init__(
        self,
        dt: float = 1.0 / 30.0,
        trial_duration: float = 3.0,
        u_max: float = float(np.radians(4.0)),
        measurement_noise_std: float | Sequence[float] = 1e-3,
        initial_mean: Sequence[float] = (0.0,) * 8,
        initial_std: float | Sequence[float] = (0.084, 0.084, 0.0, 0.0, 1e-6, 1e-6, 0.0, 0.0),
        measured_indices: Sequence[int] | None = None,
        quantization: float | Sequence[float] | None = None,
        initial_distribution: str = "uniform",
        plate_half_width: float = 0.1,
        ball_radius: float = 0.016,
        linkage_ratio: float = 1.0,
        rolling_friction: float = 0.0,
        gravity: float = 9.81,
        success_radius: float | None = None,
        success_window: float = 0.5,
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
            initial_distribution,
        )
        plate_half_width = positive("plate_half_width", plate_half_width)
        gravity = non_negative("gravity", gravity)
        success_window = positive("success_window", success_window)
        if success_radius is not None:
            success_radius = positive("success_radius", success_radius)
        if not 0 < ball_radius < plate_half_width:
            raise ConfigError(
                f"system.ball_radius={ball_radius} must be in (0, plate_half_width="
                f"{plate_half_width})"
            )
        linkage_ratio = positive("linkage_ratio", linkage_ratio)
        rolling_friction = non_negative("rolling_friction", rolling_friction)
        self.plate_half_width, self.ball_radius = plate_half_width, ball_radius
        self.linkage_ratio, self.rolling_friction = linkage_ratio, rolling_friction
        self.gravity = gravity
        self.success_radius = ball_radius if success_radius is None else success_radius
        self.success_window = success_window

    def derivatives(self, state: np.ndarray, action: np.ndarray) -> np.ndarray:
        """ẋ with the motor speeds held at the state's θ̇ (set by :meth:`step`)."""
        bx, by, vx, vy, theta1, theta2, omega1, omega2 = state
        r = self.linkage_ratio
        tilt1, tilt2, rate1, rate2 = r * theta1, r * theta2, r * omega1, r * omega2
        ax = ROLLING * (bx * rate1**2 + by * rate1 * rate2 - self.gravity * np.sin(tilt1))
        ay = ROLLING * (by * rate2**2 + bx * rate1 * rate2 - self.gravity * np.sin(tilt2))
        friction = self.rolling_friction
        return np.array([vx, vy, ax - friction * vx, ay - friction * vy, omega1, omega2, 0, 0])

    def step(self, state: np.ndarray, action: np.ndarray) -> np.ndarray:
        """The motors turn by ``action`` at constant speed over the step."""
        moving = np.array(state, dtype=np.float64)
        moving[6:8] = np.asarray(action, dtype=np.float64) / self.dt
        return super().step(moving, action)

    def known_transition(
        self, states: torch.Tensor, actions: torch.Tensor, coordinates: Sequence[int]
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """The motors (coordinates 2, 3) turn by the commanded increment at u/T_s."""
        if any(k not in self.known_coordinates for k in coordinates):
            raise ValueError(f"coordinates {list(coordinates)} are not all known (2, 3)")
        motor_actions = [self.known_coordinates.index(k) for k in coordinates]  # u1, u2
        increments = actions[..., motor_actions]
        angles = states[..., [self.position_indices[k] for k in coordinates]]
        return angles + increments, increments / self.dt

    def on_plate(self, states: np.ndarray) -> np.ndarray:
        """Whether the ball ``[..., 8]`` is clear of the border (bool ``[...]``)."""
        limit = self.plate_half_width - self.ball_radius
        return np.all(np.abs(states[..., 0:2]) <= limit, axis=-1)

    def rollout(
        self, controller: Controller, x0: np.ndarray, num_steps: int, rng: np.random.Generator
    ) -> Trajectory:
        """A closed-loop rollout, cut at the ball's first contact with the border (the data
        after a collision are not kept, thesis §3.4.2)."""
        full = super().rollout(controller, x0, num_steps, rng)
        inside = self.on_plate(full.states)
        if inside.all():
            return full
        last = max(int(np.argmin(inside)), 1)  # keep at least one transition
        return Trajectory(
            states=full.states[: last + 1],
            measurements=full.measurements[: last + 1],
            actions=full.actions[:last],
            dt=full.dt,
        )

    def velocity_basis(self, features: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        """The terms each velocity change over one step is (nearly) linear in, from the
        equations above with a unit linkage: during the step the motors turn at u/T_s and
        the tilt moves from θ to θ + u, so ball x: [bx u1², by u1 u2, sin θ1, u1 cos θ1, ḃx],
        ball y: [by u2², bx u1 u2, sin θ2, u2 cos θ2, ḃy]; motor i: [u_i, θ̇_i, 0, 0, 0] (its
        speed jumps from θ̇_i to u_i/T_s). Features x* = [bx, by, ḃx, ḃy, θ̇1, θ̇2, sin θ1,
        sin θ2, cos θ1, cos θ2]; returns ``[4, ..., 5]``."""
        bx, by, vx, vy = (features[..., k] for k in range(4))
        omega1, omega2, sin1, sin2, cos1, cos2 = (features[..., k] for k in range(4, 10))
        u1, u2 = action[..., 0], action[..., 1]
        zeros = torch.zeros_like(bx)
        ball_x = torch.stack([bx * u1.square(), by * u1 * u2, sin1, u1 * cos1, vx], -1)
        ball_y = torch.stack([by * u2.square(), bx * u1 * u2, sin2, u2 * cos2, vy], -1)
        motor1 = torch.stack([u1, omega1, zeros, zeros, zeros], -1)
        motor2 = torch.stack([u2, omega2, zeros, zeros, zeros], -1)
        return torch.stack([ball_x, ball_y, motor1, motor2], dim=0)

    def evaluation_cost(self, states: np.ndarray) -> np.ndarray:
        """The training cost (3.3) per state ``[T+1]``."""
        return ball_and_plate_cost(states)

    def evaluate(self, trajectory: Trajectory) -> dict[str, float]:
        """Cumulative cost (3.3); steady-state error: the ball's mean distance from the
        centre over the last ``success_window`` s; success: that error below
        ``success_radius`` on a trajectory that kept the ball on the plate to the end."""
        states = trajectory.states
        window = trajectory.times >= trajectory.times[-1] - self.success_window - 1e-9
        error = float(np.mean(np.linalg.norm(states[window, 0:2], axis=-1)))
        complete = states.shape[0] == self.num_steps + 1
        return {
            "eval_cost": float(ball_and_plate_cost(states).sum()),
            "success": bool(complete and error < self.success_radius),
            "steady_state_error": error,
            "collided": not complete,
        }

    def sketch(self, states: np.ndarray) -> np.ndarray:
        """Top view: the plate's border and a cross at the ball, ``[T+1, 6, 2, 2]`` (m)."""
        h, r = self.plate_half_width, self.ball_radius
        corners = np.array([[-h, -h], [h, -h], [h, h], [-h, h]])
        border = np.stack([corners, np.roll(corners, -1, axis=0)], axis=1)  # [4, 2, 2]
        frames = np.broadcast_to(border, (states.shape[0], 4, 2, 2))
        bx, by = states[:, 0], states[:, 1]
        horizontal = np.stack([np.stack([bx - r, by], -1), np.stack([bx + r, by], -1)], 1)
        vertical = np.stack([np.stack([bx, by - r], -1), np.stack([bx, by + r], -1)], 1)
        return np.concatenate([frames, horizontal[:, None], vertical[:, None]], axis=1)
