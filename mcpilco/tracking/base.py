"""The observer interface the trial loop reports to (loggers, live viewers)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from mcpilco.extension import ExtensionPoint
from mcpilco.trajectory import Trajectory


class TrialObserver(ExtensionPoint):
    """No-op hooks; a logger overrides the ones it needs. Called in this order per trial:
    ``model_fitted`` → ``optimized`` → ``particles_predicted`` → ``rollout`` →
    ``trial_finished`` (the exploration rollout, trial 0, has only the last two)."""

    wants_particles: bool = False
    """Whether the trial loop should simulate the final policy's particles for this one."""

    def run_started(self, metadata: Mapping[str, str], resumed_after: int) -> None:
        """Once, before the first trial runs; ``resumed_after`` is −1 for a new run."""

    def model_fitted(self, trial: int, hyperparameters: Mapping[str, list[float]]) -> None:
        """GP hyper-parameters (constrained values) after the fit of ``trial``."""

    def optimized(self, trial: int, trace: Mapping[str, list[float]]) -> None:
        """Per-step optimisation trace: cost, dropout, learning_rate, signal."""

    def particles_predicted(
        self, trial: int, states: np.ndarray, costs: np.ndarray, dt: float
    ) -> None:
        """Particles of the final policy on the model: states ``[T+1, M, d_x]``, costs
        ``[T+1, M]`` (training cost)."""

    def rollout(
        self,
        trial: int,
        trajectory: Trajectory,
        costs: np.ndarray,
        eval_costs: np.ndarray,
        kind: str | None = None,
    ) -> None:
        """A system rollout with its training cost and evaluation cost per state ``[T+1]``;
        ``kind`` labels it (None: ``exploration`` for trial 0, ``policy`` after)."""

    def trial_finished(self, trial: int, summary: Mapping[str, Any]) -> None:
        """The trial's summary row; everything of the trial must be durable after this."""

    def close(self) -> None:
        """End of the run (or of the process)."""
