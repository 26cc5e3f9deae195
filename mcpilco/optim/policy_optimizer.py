"""Adam on the Monte Carlo cost with the monitoring-signal schedule (Algorithm 1, step 2)."""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

import torch
from torch import nn

from mcpilco.errors import ConfigError
from mcpilco.optim.monitor import MonitoringSchedule
from mcpilco.optim.rollout import ParticleRollout

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class StepInfo:
    """One optimisation step, for progress bars and logs."""

    step: int
    cost: float
    dropout: float
    learning_rate: float
    signal: float


@dataclass
class OptimizationResult:
    """Trace of a policy optimisation: one entry per step."""

    costs: list[float] = field(default_factory=list)
    dropouts: list[float] = field(default_factory=list)
    learning_rates: list[float] = field(default_factory=list)
    signals: list[float] = field(default_factory=list)
    restarts: int = 0

    @property
    def steps(self) -> int:
        return len(self.costs)


@contextmanager
def frozen(module: nn.Module) -> Iterator[None]:
    """Temporarily stop gradients to ``module``'s parameters (GP hyper-parameters)."""
    flags = [(p, p.requires_grad) for p in module.parameters()]
    for parameter, _ in flags:
        parameter.requires_grad_(False)
    try:
        yield
    finally:
        for parameter, flag in flags:
            parameter.requires_grad_(flag)


class PolicyOptimizer:
    """Optimises a policy on M particles simulated with the learned model.

    Args:
        num_particles: M.
        max_steps: N_opt per trial; ``max_steps_first_trial`` for trial 1 (reference: 2000
            then 4000).
        schedule: monitoring-schedule parameters (Table 2.1 defaults), see
            :class:`MonitoringSchedule`.
        max_nan_retries: consecutive non-finite costs tolerated before the policy is
            re-initialised.
        restart_adam_on_reduction: at each reduction of the schedule (2.14) start a fresh
            Adam (moment estimates and bias correction reset) at the new α_lr, as the public
            reference code does; false only lowers the learning rate of the running Adam.
    """

    def __init__(
        self,
        num_particles: int = 400,
        max_steps: int = 4000,
        max_steps_first_trial: int = 2000,
        schedule: dict[str, float] | None = None,
        max_nan_retries: int = 10,
        restart_adam_on_reduction: bool = False,
    ) -> None:
        for key, value in (
            ("num_particles", num_particles),
            ("max_steps", max_steps),
            ("max_steps_first_trial", max_steps_first_trial),
        ):
            if not isinstance(value, int) or value < 1:
                raise ConfigError(f"optimizer.{key} must be a positive integer, got {value!r}")
        self.num_particles = num_particles
        self.max_steps = max_steps
        self.max_steps_first_trial = max_steps_first_trial
        self.schedule_options = dict(schedule or {})
        MonitoringSchedule(**self.schedule_options)  # validate now, before any work
        self.max_nan_retries = max_nan_retries
        if not isinstance(restart_adam_on_reduction, bool):
            raise ConfigError(
                "optimizer.restart_adam_on_reduction must be true or false, "
                f"got {restart_adam_on_reduction!r}"
            )
        self.restart_adam_on_reduction = restart_adam_on_reduction

    def optimize(
        self,
        rollout: ParticleRollout,
        trial: int,
        generator: torch.Generator | None,
        on_step: Callable[[StepInfo], None] | None = None,
    ) -> OptimizationResult:
        """Run Adam until the schedule stops it or N_opt steps are done."""
        policy, model = rollout.policy, rollout.model
        schedule = MonitoringSchedule(**self.schedule_options)
        optimizer = torch.optim.Adam(policy.parameters(), lr=schedule.learning_rate)
        result = OptimizationResult()
        limit = self.max_steps_first_trial if trial <= 1 else self.max_steps
        failures = 0
        with frozen(model):
            for step in range(limit):
                dropout = max(schedule.dropout, 0.0)
                optimizer.zero_grad(set_to_none=True)
                total = rollout(self.num_particles, dropout, generator).total_cost
                if not torch.isfinite(total):
                    failures += 1
                    if failures > self.max_nan_retries:
                        log.warning(
                            "trial %d: cost not finite %d times; new policy", trial, failures
                        )
                        policy.reset_parameters(generator)
                        optimizer = torch.optim.Adam(policy.parameters(), lr=schedule.learning_rate)
                        result.restarts += 1
                        failures = 0
                    continue
                failures = 0
                total.backward()
                optimizer.step()
                cost = float(total.detach())
                event = schedule.update(cost)
                if event.reduced and self.restart_adam_on_reduction:
                    optimizer = torch.optim.Adam(policy.parameters(), lr=schedule.learning_rate)
                for group in optimizer.param_groups:
                    group["lr"] = schedule.learning_rate
                result.costs.append(cost)
                result.dropouts.append(dropout)
                result.learning_rates.append(schedule.learning_rate)
                result.signals.append(event.signal)
                if on_step is not None:
                    on_step(StepInfo(step, cost, dropout, schedule.learning_rate, event.signal))
                if event.stop:
                    break
        if not result.costs or not math.isfinite(result.costs[-1]):
            log.warning("trial %d: policy optimisation made no finite step", trial)
        return result
