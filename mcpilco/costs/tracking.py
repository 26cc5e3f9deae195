"""Tracking cost for reference-following tasks (thesis §2.6.3, the UR5)."""

from __future__ import annotations

import torch

from mcpilco.costs.base import Cost
from mcpilco.errors import ConfigError
from mcpilco.systems.base import MechanicalSystem


class TrackingCost(Cost):
    """c(x_t) = 1 − exp(−(‖q_ref,t − q_t‖/ℓ_q)² − (‖q̇_ref,t − q̇_t‖/ℓ_q̇)²) against the
    system's reference states (its ``reference_states``), so the cost depends on the time
    index: apply it to whole trajectories ``[T'+1, ..., d_x]`` starting at t = 0.

    Args:
        system: a tracking task (built first; the config is a ``_partial_``).
        position_scale: ℓ_q (the thesis: 0.5 rad; 1 rad in the DF experiment, §4.3).
        velocity_scale: ℓ_q̇ (1 rad/s); None drops the velocity term (DF, §4.3:
            c = 1 − exp(−‖e‖²)).
    """

    def __init__(
        self,
        system: MechanicalSystem,
        position_scale: float = 0.5,
        velocity_scale: float | None = 1.0,
    ) -> None:
        super().__init__()
        if system.reference_states is None:
            raise ConfigError(
                f"cost=tracking needs a tracking task; {type(system).__name__} has no reference"
            )
        if position_scale <= 0 or (velocity_scale is not None and velocity_scale <= 0):
            raise ConfigError(
                f"cost.position_scale={position_scale} and cost.velocity_scale="
                f"{velocity_scale} must be > 0"
            )
        self.position_indices = list(system.position_indices)
        self.velocity_indices = list(system.velocity_indices)
        self.position_scale, self.velocity_scale = position_scale, velocity_scale
        reference = torch.as_tensor(system.reference_states, dtype=torch.float64)
        self.register_buffer("reference", reference, persistent=False)  # [T+1, d_x]

    def forward(self, states: torch.Tensor) -> torch.Tensor:
        """Cost ``[T'+1, ...]`` of a trajectory ``[T'+1, ..., d_x]`` (T' ≤ T)."""
        steps = states.shape[0]
        if steps > self.reference.shape[0]:
            raise ValueError(f"trajectory of {steps} samples exceeds the reference's length")
        reference = self.reference[:steps].reshape(steps, *([1] * (states.dim() - 2)), -1)
        error = reference - states
        position = error[..., self.position_indices].square().sum(-1)
        exponent = position / self.position_scale**2
        if self.velocity_scale is not None:
            velocity = error[..., self.velocity_indices].square().sum(-1)
            exponent = exponent + velocity / self.velocity_scale**2
        return 1.0 - torch.exp(-exponent)
