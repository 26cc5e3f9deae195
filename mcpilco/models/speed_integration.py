"""Speed-integration model (thesis §2.3.1, eq. 2.7–2.8)."""

from __future__ import annotations

import torch

from mcpilco.models.base import ModelStructure
from mcpilco.models.features import selection_matrix


class SpeedIntegration(ModelStructure):
    """d_q GPs predict velocity changes Δ; positions follow by constant acceleration.

    q̇_{t+1} = q̇_t + Δ_t,   q_{t+1} = q_t + T_s q̇_t + (T_s/2) Δ_t,

    written as ``x_{t+1} = x_t A + Δ_t B`` with constant ``A [d_x, d_x]``, ``B [d_q, d_x]``.
    """

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]
        system = self.system
        dt, dim = system.dt, system.state_dim
        to_positions = selection_matrix(dim, system.position_indices).T  # [d_q, d_x]
        to_velocities = selection_matrix(dim, system.velocity_indices).T  # [d_q, d_x]
        velocity_select = to_velocities.T  # [d_x, d_q]: x @ it = q̇
        state_map = torch.eye(dim, dtype=torch.float64) + dt * velocity_select @ to_positions
        self.register_buffer("state_map", state_map, persistent=False)
        self.register_buffer("delta_map", 0.5 * dt * to_positions + to_velocities, persistent=False)
        self.register_buffer("velocity_select", velocity_select, persistent=False)

    @property
    def output_names(self) -> list[str]:
        return [f"d_x{i}" for i in self.system.velocity_indices]

    def gp_targets(self, states: torch.Tensor) -> torch.Tensor:
        velocities = torch.matmul(states, self.velocity_select)
        return velocities[1:] - velocities[:-1]

    def transition(
        self, particles: torch.Tensor, actions: torch.Tensor, deltas: torch.Tensor
    ) -> torch.Tensor:
        return torch.addmm(torch.matmul(particles, self.state_map), deltas.T, self.delta_map)

    def output_basis(self, gp_inputs: torch.Tensor) -> torch.Tensor:
        split = self.features.dim
        return self.system.velocity_basis(gp_inputs[..., :split], gp_inputs[..., split:])
