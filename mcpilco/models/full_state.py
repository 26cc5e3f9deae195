"""Full-state model: one GP per state component (thesis §2.1.2)."""

from __future__ import annotations

import torch

from mcpilco.models.base import ModelStructure


class FullState(ModelStructure):
    """d_x GPs predict x_{t+1} − x_t."""

    @property
    def output_names(self) -> list[str]:
        return [f"d_x{i}" for i in range(self.system.state_dim)]

    def gp_targets(self, states: torch.Tensor) -> torch.Tensor:
        return states[1:] - states[:-1]

    def transition(
        self, particles: torch.Tensor, actions: torch.Tensor, deltas: torch.Tensor
    ) -> torch.Tensor:
        return particles + deltas.T

    def output_basis(self, gp_inputs: torch.Tensor) -> torch.Tensor:
        """Position outputs use [q̇_k, φ_k]; velocity outputs use [q̇_k, φ_k] too.

        (Δq ≈ T_s q̇ + T_s²/2 q̈, and q̈ is linear in φ; q̇_k is a harmless extra
        feature for the velocity change.)
        """
        split = self.features.dim
        features = gp_inputs[..., :split]
        basis = self.system.velocity_basis(features, gp_inputs[..., split:])  # [d_q, N, P]
        system = self.system
        rows = []
        for component in range(system.state_dim):
            k = (
                system.position_indices.index(component)
                if component in system.position_indices
                else system.velocity_indices.index(component)
            )
            column = self.features.other_indices.index(system.velocity_indices[k])
            rows.append(torch.cat([features[..., column : column + 1], basis[k]], dim=-1))
        return torch.stack(rows)
