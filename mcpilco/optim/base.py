"""The policy-search interface: what turns a fitted model into a better policy."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import torch

from mcpilco.errors import ConfigError
from mcpilco.extension import ExtensionPoint

if TYPE_CHECKING:
    from mcpilco.optim.rollout import ParticleRollout


@dataclass(frozen=True)
class StepInfo:
    """One optimisation step, for progress bars and logs (``horizon``: the rollout's length in
    steps, shorter than the trial in the early stages of a horizon curriculum)."""

    step: int
    cost: float
    dropout: float
    learning_rate: float
    signal: float
    horizon: int


@dataclass
class OptimizationResult:
    """Trace of a policy optimisation: one entry per step (an Adam step, an L-BFGS objective
    evaluation, a CMA-ES generation)."""

    costs: list[float] = field(default_factory=list)
    dropouts: list[float] = field(default_factory=list)
    learning_rates: list[float] = field(default_factory=list)
    signals: list[float] = field(default_factory=list)
    horizons: list[int] = field(default_factory=list)
    restarts: int = 0

    @property
    def steps(self) -> int:
        return len(self.costs)

    def append(self, info: StepInfo) -> None:
        """Record one step."""
        self.costs.append(info.cost)
        self.dropouts.append(info.dropout)
        self.learning_rates.append(info.learning_rate)
        self.signals.append(info.signal)
        self.horizons.append(info.horizon)


def require_positive_integers(**values: object) -> None:
    """One-line :class:`ConfigError` naming ``optimizer.<key>`` for the first value that is
    not a positive integer (config validation shared by the searches)."""
    for key, value in values.items():
        if not isinstance(value, int) or isinstance(value, bool) or value < 1:
            raise ConfigError(f"optimizer.{key} must be a positive integer, got {value!r}")


class PolicySearch(ExtensionPoint, ABC):
    """A policy-search algorithm (config group ``algorithm``, node ``optimizer``): MC-PILCO's
    Adam on particles, PILCO's moment matching, Black-DROPS's CMA-ES. Subclass it for your
    own and name it with ``optimizer._target_=my_pkg.MySearch``.

    ``num_particles`` is also the number of particles the trial loop simulates with the final
    policy for the loggers and the calibration figures.
    """

    num_particles: int

    @abstractmethod
    def optimize(
        self,
        rollout: ParticleRollout,
        trial: int,
        generator: torch.Generator | None,
        on_step: Callable[[StepInfo], None] | None = None,
    ) -> OptimizationResult:
        """Improve ``rollout.policy`` in place on the fitted ``rollout.model``."""

    def step_budget(self, trial: int) -> int | None:
        """The most optimisation steps (``on_step`` calls) trial ``trial`` may take, for a
        progress bar's total and time estimate; None where the search does not know."""
        return None

    def check(self, rollout: ParticleRollout) -> None:  # noqa: B027 - optional hook
        """Refuse, with a one-line :class:`~mcpilco.errors.ConfigError` naming the config
        key, a model, kernel, policy or cost this search cannot work with (called before
        any work). Accepts everything by default."""
