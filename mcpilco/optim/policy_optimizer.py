"""Adam on the Monte Carlo cost with the monitoring-signal schedule (Algorithm 1, step 2)."""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager

import torch
from torch import nn

from mcpilco.errors import ConfigError
from mcpilco.optim.base import (
    OptimizationResult,
    PolicySearch,
    StepInfo,
    require_positive_integers,
)
from mcpilco.optim.compile_choice import CompileChoice
from mcpilco.optim.monitor import MonitoringSchedule
from mcpilco.optim.rollout import ParticleRollout

log = logging.getLogger(__name__)


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


class PolicyOptimizer(PolicySearch):
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
        horizon_stages: a horizon curriculum (not in the thesis; None: off, the thesis's
            search). Increasing fractions of the trial's horizon ending at 1.0, e.g.
            ``[0.33, 0.5, 0.67, 0.83, 1.0]``: the trial's N_opt steps are shared equally
            among the stages; stage k optimises Ĵ over the first ⌈f_k T⌉ steps only, with a
            fresh Adam and monitoring schedule, starting from the policy of stage k − 1.
            Dropout acts in the first stage only: the schedule ends it there (p_d < 0), and
            restarting it at p_d would perturb a policy that has just learnt to balance
            (measured: Ĵ 19 → 72 at the first step of a stage that did). Short rollouts first
            make the search learn the beginning of the task (for the Furuta pendulum: the
            swing-up) before a longer horizon asks it to hold the result
            (measured: docs/results/furuta_quick/README.md).
    """

    def __init__(
        self,
        num_particles: int = 400,
        max_steps: int = 4000,
        max_steps_first_trial: int = 2000,
        schedule: dict[str, float] | None = None,
        max_nan_retries: int = 10,
        restart_adam_on_reduction: bool = False,
        horizon_stages: Sequence[float] | None = None,
    ) -> None:
        require_positive_integers(
            num_particles=num_particles,
            max_steps=max_steps,
            max_steps_first_trial=max_steps_first_trial,
        )
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
        self.horizon_stages = _checked_stages(horizon_stages)

    def stage_plan(self, horizon: int, limit: int) -> list[tuple[int, int]]:
        """(rollout horizon in steps, optimisation steps) per stage for a trial with horizon T
        and N_opt = ``limit``: one stage (T, N_opt) without a curriculum."""
        if self.horizon_stages is None:
            return [(horizon, limit)]
        count = len(self.horizon_stages)
        shares = [limit // count] * count
        shares[-1] += limit - sum(shares)
        return [
            (max(1, math.ceil(fraction * horizon - 1e-9)), share)
            for fraction, share in zip(self.horizon_stages, shares, strict=True)
        ]

    def step_budget(self, trial: int) -> int:
        """N_opt of trial ``trial`` (the monitoring signal may stop it earlier)."""
        return self.max_steps_first_trial if trial <= 1 else self.max_steps

    def optimize(
        self,
        rollout: ParticleRollout,
        trial: int,
        generator: torch.Generator | None,
        on_step: Callable[[StepInfo], None] | None = None,
    ) -> OptimizationResult:
        """Run Adam until the schedule stops it or N_opt steps are done (per stage of the
        horizon curriculum, when there is one); the rollout's horizon is restored after."""
        limit = self.max_steps_first_trial if trial <= 1 else self.max_steps
        result = OptimizationResult()
        full_horizon = rollout.horizon
        try:
            for stage, (horizon, steps) in enumerate(self.stage_plan(full_horizon, limit)):
                rollout.horizon = horizon
                options = dict(self.schedule_options)
                if stage > 0:
                    options.update(dropout=0.0, dropout_step=0.0)
                self._optimize_stage(rollout, trial, generator, steps, options, result, on_step)
        finally:
            rollout.horizon = full_horizon
        if not result.costs or not math.isfinite(result.costs[-1]):
            log.warning("trial %d: policy optimisation made no finite step", trial)
        return result

    def _optimize_stage(
        self,
        rollout: ParticleRollout,
        trial: int,
        generator: torch.Generator | None,
        limit: int,
        schedule_options: dict[str, float],
        result: OptimizationResult,
        on_step: Callable[[StepInfo], None] | None,
    ) -> None:
        """Adam with a fresh monitoring schedule (``schedule_options``) for at most ``limit``
        steps on the rollout as it is (its horizon set by the caller); appends each step to
        ``result``."""
        policy, model = rollout.policy, rollout.model
        schedule = MonitoringSchedule(**schedule_options)
        optimizer = torch.optim.Adam(policy.parameters(), lr=schedule.learning_rate)
        failures = 0
        choice = CompileChoice(getattr(rollout, "compiler", None))
        with frozen(model):
            for step in range(limit):
                started = time.perf_counter()
                choice.before(step)
                dropout = max(schedule.dropout, 0.0)
                optimizer.zero_grad(set_to_none=True)
                draws = _draws_to_replay(rollout, generator)
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
                try:
                    total.backward()
                except Exception as error:  # noqa: BLE001 - a compiler failure: replay eagerly
                    if draws is None:
                        raise
                    # the backward graphs compile at the first backward pass, outside the
                    # rollout's own fallback (e.g. a kernel cache truncated by a killed run)
                    rollout.compiler.stop_compiling(error)
                    optimizer.zero_grad(set_to_none=True)
                    generator.set_state(draws)  # type: ignore[union-attr]
                    total = rollout(self.num_particles, dropout, generator).total_cost
                    if not torch.isfinite(total):
                        continue  # the eager replay's rounding: the next step tries again
                    total.backward()
                optimizer.step()
                choice.after(step, time.perf_counter() - started)
                cost = float(total.detach())
                event = schedule.update(cost)
                if event.reduced and self.restart_adam_on_reduction:
                    optimizer = torch.optim.Adam(policy.parameters(), lr=schedule.learning_rate)
                for group in optimizer.param_groups:
                    group["lr"] = schedule.learning_rate
                info = StepInfo(
                    result.steps,
                    cost,
                    dropout,
                    schedule.learning_rate,
                    event.signal,
                    rollout.horizon,
                )
                result.append(info)
                if on_step is not None:
                    on_step(info)
                if event.stop:
                    break


def _draws_to_replay(
    rollout: ParticleRollout, generator: torch.Generator | None
) -> torch.Tensor | None:
    """The generator's state before a compiled rollout (None for an eager one, or with
    no generator): a step whose backward fails to compile is replayed eagerly from it."""
    compiler = getattr(rollout, "compiler", None)
    if generator is None or compiler is None or not compiler.compile:
        return None
    return generator.get_state()


def _checked_stages(stages: Sequence[float] | None) -> tuple[float, ...] | None:
    """The horizon curriculum's fractions, validated: increasing, in (0, 1], ending at 1."""
    if stages is None:
        return None
    try:
        fractions = tuple(float(f) for f in stages)
    except (TypeError, ValueError):
        raise ConfigError(
            f"optimizer.horizon_stages must be a list of numbers, got {stages!r}"
        ) from None
    if (
        not fractions
        or fractions[-1] != 1.0
        or any(not 0.0 < f <= 1.0 for f in fractions)
        or any(b <= a for a, b in zip(fractions[:-1], fractions[1:], strict=True))
    ):
        raise ConfigError(
            "optimizer.horizon_stages must increase within (0, 1] and end at 1.0, "
            f"got {list(stages)!r}"
        )
    return fractions
