"""Speed-integration model (thesis §2.3.1, eq. 2.7–2.8)."""

from __future__ import annotations

from collections.abc import Callable

import torch

from mcpilco.errors import ConfigError
from mcpilco.gp.fit import MarginalLikelihoodFit
from mcpilco.kernels.base import KernelFactory
from mcpilco.models.base import ModelStructure
from mcpilco.models.features import selection_matrix
from mcpilco.systems.base import MechanicalSystem


class SpeedIntegration(ModelStructure):
    """GPs predict velocity changes Δ; positions follow by constant acceleration.

    q̇_{t+1} = q̇_t + Δ_t,   q_{t+1} = q_t + T_s q̇_t + (T_s/2) Δ_t,

    written as ``x_{t+1} = x_t A + Δ_t B`` with constant ``A [d_x, d_x]``, ``B [d_q, d_x]``.

    With ``known_coordinates`` the coordinates the system moves deterministically (its
    ``known_coordinates``, e.g. position-controlled motors that turn by the commanded
    increment) get no GP: their next position and velocity come from the system's
    :meth:`~mcpilco.systems.base.MechanicalSystem.known_transition` (thesis §3.4.2: the
    ball-and-plate learns only the ball's two velocities).

    Args:
        known_coordinates: take the system's known coordinates from it instead of GPs.
        Others: see :class:`ModelStructure`.
    """

    def __init__(
        self,
        system: MechanicalSystem,
        kernel: KernelFactory,
        gp: Callable[..., object],
        fit: MarginalLikelihoodFit,
        reduction_threshold: float | None = None,
        reduction_mode: str = "absolute",
        known_coordinates: bool = False,
    ) -> None:
        super().__init__(  # type: ignore[arg-type]
            system, kernel, gp, fit, reduction_threshold, reduction_mode
        )
        dt, dim = system.dt, system.state_dim
        known = tuple(system.known_coordinates) if known_coordinates else ()
        if known_coordinates and not known:
            raise ConfigError(
                f"model.known_coordinates=true but {type(system).__name__} knows no coordinate"
            )
        self.known = known
        self.learned = tuple(k for k in range(len(system.position_indices)) if k not in known)
        learned_velocities = [system.velocity_indices[k] for k in self.learned]
        to_positions = selection_matrix(dim, system.position_indices).T  # [d_q, d_x]
        to_velocities = selection_matrix(dim, system.velocity_indices).T  # [d_q, d_x]
        velocity_select = to_velocities.T  # [d_x, d_q]: x @ it = q̇
        state_map = torch.eye(dim, dtype=torch.float64) + dt * velocity_select @ to_positions
        delta_map = (0.5 * dt * to_positions + to_velocities)[list(self.learned)]
        components = [system.position_indices[k] for k in known]
        components += [system.velocity_indices[k] for k in known]
        keep = torch.ones(dim, dtype=torch.float64)
        keep[components] = 0.0
        self.register_buffer("state_map", state_map * keep, persistent=False)
        self.register_buffer("delta_map", delta_map * keep, persistent=False)
        self.register_buffer(
            "known_embed", selection_matrix(dim, components).T.contiguous(), persistent=False
        )
        self.register_buffer(
            "velocity_select", selection_matrix(dim, learned_velocities), persistent=False
        )

    @property
    def output_names(self) -> list[str]:
        return [f"d_x{self.system.velocity_indices[k]}" for k in self.learned]

    def gp_targets(self, states: torch.Tensor) -> torch.Tensor:
        velocities = torch.matmul(states, self.velocity_select.to(states.dtype))
        return velocities[1:] - velocities[:-1]

    def transition(
        self, particles: torch.Tensor, actions: torch.Tensor, deltas: torch.Tensor
    ) -> torch.Tensor:
        following = torch.addmm(torch.matmul(particles, self.state_map), deltas.T, self.delta_map)
        if not self.known:
            return following
        positions, velocities = self.system.known_transition(particles, actions, self.known)
        known = torch.cat([positions, velocities], dim=-1)  # [M, 2k]
        return torch.addmm(following, known, self.known_embed)

    def output_basis(self, gp_inputs: torch.Tensor) -> torch.Tensor:
        split = self.features.dim
        basis = self.system.velocity_basis(gp_inputs[..., :split], gp_inputs[..., split:])
        return basis[list(self.learned)]
