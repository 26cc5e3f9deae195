"""Known environments' equations of motion in torch, for the true-dynamics diagnostic
(``model=true_dynamics`` on a Gymnasium system: a policy search on the plant's own
equations tells a search failure from a model error)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import torch

TorchStep = Callable[[torch.Tensor, torch.Tensor], torch.Tensor]


def pendulum_v1(env: Any) -> TorchStep:
    """Gymnasium's Pendulum-v1 (its ``step``, from the environment's own parameters g, m,
    l, dt, max_speed): θ̇' = clip(θ̇ + (3g/(2l) sin θ + 3/(m l²) u) dt, ±max_speed), θ' = θ +
    θ̇' dt (semi-implicit Euler), on states ``[..., 2]`` = [θ, θ̇] and actions ``[..., 1]``."""
    unwrapped = env.unwrapped
    g, m, length = float(unwrapped.g), float(unwrapped.m), float(unwrapped.l)
    dt = float(unwrapped.dt)
    max_speed, max_torque = float(unwrapped.max_speed), float(unwrapped.max_torque)

    def step(states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        theta, rate = states[..., 0], states[..., 1]
        torque = actions[..., 0].clamp(-max_torque, max_torque)
        acceleration = 3 * g / (2 * length) * torch.sin(theta) + 3.0 / (m * length**2) * torque
        new_rate = (rate + acceleration * dt).clamp(-max_speed, max_speed)
        return torch.stack([theta + new_rate * dt, new_rate], dim=-1)

    return step


KNOWN: dict[str, Callable[[Any], TorchStep]] = {"Pendulum-v1": pendulum_v1}
"""Environment id → its equations (keyed by id: nothing is looked up by a name in config)."""
