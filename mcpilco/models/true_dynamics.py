"""The system's own equations of motion as the model: a diagnostic for the policy search."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch

from mcpilco.errors import ConfigError
from mcpilco.models.base import FitReport
from mcpilco.models.speed_integration import SpeedIntegration
from mcpilco.systems.base import OdeSystem


class TrueDynamics(SpeedIntegration):
    """Particles move by the plant's exact ODE instead of GPs (no noise, nothing to fit).

    Optimising a policy on this model tells model error apart from policy-search failure:
    if the optimiser cannot solve a task even here, no GP will make it. Each step holds
    the action over T_s and integrates :meth:`~mcpilco.systems.base.OdeSystem.torch_derivatives`
    with ``substeps`` classical Runge–Kutta (RK4) steps, differentiably (or, for a system
    with a discrete ``torch_step`` such as a Gymnasium environment whose equations are
    known, one step of it). The particles,
    features and policy inputs are those of :class:`SpeedIntegration`, so estimators and
    policies see exactly what they see in a learning run.

    Args:
        substeps: RK4 steps per sampling period.
        Others: see :class:`SpeedIntegration` (kernel and GP factories are kept only so
            the structure is built like the others; no GP is ever made).
    """

    fits_gps = False

    def __init__(self, *args: object, substeps: int = 4, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]
        self.discrete = callable(getattr(self.system, "torch_step", None))
        if not isinstance(self.system, OdeSystem) and not self.discrete:
            raise ConfigError(
                "the true-dynamics model needs an ODE system with torch equations of motion "
                f"(or a system with a torch_step), got {type(self.system).__name__}"
            )
        try:
            probe = torch.zeros(1, self.system.state_dim, dtype=torch.float64)
            equations = self.system.torch_step if self.discrete else self.system.torch_derivatives  # type: ignore[attr-defined]
            equations(probe, probe.new_zeros(1, self.system.action_dim))
        except NotImplementedError as error:
            raise ConfigError(f"the true-dynamics model: {error}") from None
        if not isinstance(substeps, int) or substeps < 1:
            raise ConfigError(f"model.substeps must be a positive integer, got {substeps!r}")
        self.substeps = substeps

    def fit(self, states: Sequence[np.ndarray], actions: Sequence[np.ndarray]) -> FitReport:
        """Nothing to learn; reports the data size it was given."""
        count = sum(len(a) for a in actions)
        return FitReport(count, count, float("nan"), 0.0)

    def checkpoint(self) -> dict[str, torch.Tensor]:
        return {}

    def hyperparameters(self) -> dict[str, list[float]]:
        return {}

    def load_gp(self, state: dict[str, torch.Tensor]) -> None:
        """Nothing to restore (the checkpoint is empty)."""

    def step(
        self,
        particles: torch.Tensor,
        actions: torch.Tensor,
        noise: torch.Tensor,
        encoded: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """Next states ``[M, d_x]`` from states ``[M, d_x]`` and actions ``[M, d_u]``
        (``noise`` and ``encoded`` are ignored: the plant is deterministic). A system with
        a discrete ``torch_step`` (a Gymnasium environment's own update) steps by it."""
        if self.discrete:
            return self.system.torch_step(particles, actions)  # type: ignore[attr-defined]
        derivatives = self.system.torch_derivatives  # type: ignore[attr-defined]
        h = self.system.dt / self.substeps
        state = particles
        for _ in range(self.substeps):
            k1 = derivatives(state, actions)
            k2 = derivatives(state + 0.5 * h * k1, actions)
            k3 = derivatives(state + 0.5 * h * k2, actions)
            k4 = derivatives(state + h * k3, actions)
            state = state + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        return state
