"""Angles enter GP and policy inputs as (sin, cos) (thesis §2.5)."""

from __future__ import annotations

from collections.abc import Sequence

import torch
from torch import nn


def selection_matrix(state_dim: int, indices: Sequence[int]) -> torch.Tensor:
    """``E [d_x, k]`` with ``x @ E == x[..., indices]`` (a matmul is cheaper than gather in
    autograd's backward pass for the small particle batches here)."""
    matrix = torch.zeros(state_dim, len(indices), dtype=torch.float64)
    matrix[list(indices), range(len(indices))] = 1.0
    return matrix


class AngleFeatures(nn.Module):
    """x ``[..., d_x]`` ↔ x* ``[..., d_x + n_angles]`` = [other components, sin θ, cos θ].

    For the cart-pole, ``[p, ṗ, θ, θ̇] → [p, ṗ, θ̇, sin θ, cos θ]``.
    """

    def __init__(self, state_dim: int, angle_indices: Sequence[int]) -> None:
        super().__init__()
        self.state_dim = state_dim
        self.angle_indices = list(angle_indices)
        self.other_indices = [i for i in range(state_dim) if i not in self.angle_indices]
        self.dim = state_dim + len(self.angle_indices)
        self.register_buffer(
            "select_other", selection_matrix(state_dim, self.other_indices), persistent=False
        )
        self.register_buffer(
            "select_angles", selection_matrix(state_dim, self.angle_indices), persistent=False
        )
        order = self.other_indices + self.angle_indices
        self.register_buffer(
            "restore_order",
            selection_matrix(state_dim, order).T.contiguous(),
            persistent=False,
        )

    @property
    def angle_columns(self) -> list[tuple[int, int]]:
        """(sin θ, cos θ) column pairs of x*, one per angle."""
        n_other, n_angles = len(self.other_indices), len(self.angle_indices)
        return [(n_other + k, n_other + n_angles + k) for k in range(n_angles)]

    def encode(self, state: torch.Tensor) -> torch.Tensor:
        """x* from x."""
        if not self.angle_indices:
            return state
        angles = torch.matmul(state, self.select_angles)
        others = torch.matmul(state, self.select_other)
        return torch.cat([others, angles.sin(), angles.cos()], dim=-1)

    def decode(self, features: torch.Tensor) -> torch.Tensor:
        """x from x*, angles in (−π, π]."""
        if not self.angle_indices:
            return features
        n_other, n_angles = len(self.other_indices), len(self.angle_indices)
        sin = features[..., n_other : n_other + n_angles]
        cos = features[..., n_other + n_angles : n_other + 2 * n_angles]
        columns = torch.cat([features[..., :n_other], torch.atan2(sin, cos)], dim=-1)
        return torch.matmul(columns, self.restore_order.to(columns.dtype))
