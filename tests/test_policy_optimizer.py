"""Policy optimiser: Adam restarted (or not) at a schedule reduction, against Adam's formula."""

from __future__ import annotations

from dataclasses import dataclass

import pytest
import torch
from torch import nn

from mcpilco.errors import ConfigError
from mcpilco.optim import PolicyOptimizer

REDUCTION_STEP = 3  # window 3 with an always-met threshold: the first reduction after step 3


@dataclass
class _Cost:
    total_cost: torch.Tensor


class LinearCostRollout:
    """Ĵ(θ) = s_j θ for one scalar parameter θ: gradient 1e-3 up to the reduction, 1 after,
    so Adam's moment estimates before the reduction change the step after it. Records θ
    at every call."""

    def __init__(self) -> None:
        self.policy = nn.Module()
        self.policy.theta = nn.Parameter(torch.zeros((), dtype=torch.float64))
        self.model = nn.Module()
        self.horizon = 1
        self.thetas: list[float] = []

    def __call__(self, particles: int, dropout: float, generator: object) -> _Cost:
        step = len(self.thetas)
        self.thetas.append(float(self.policy.theta.detach()))
        scale = 1e-3 if step <= REDUCTION_STEP else 1.0
        return _Cost(scale * self.policy.theta + float(step))


def run(restart: bool) -> list[float]:
    rollout = LinearCostRollout()
    schedule = {
        "window": REDUCTION_STEP,
        "threshold": 1e9,
        "dropout_step": 0.0,
        "learning_rate": 0.01,
        "learning_rate_min": 1e-9,
        "factor": 0.5,
    }
    optimizer = PolicyOptimizer(
        num_particles=1,
        max_steps=REDUCTION_STEP + 3,
        max_steps_first_trial=REDUCTION_STEP + 3,
        schedule=schedule,
        restart_adam_on_reduction=restart,
    )
    optimizer.optimize(rollout, trial=1, generator=None)  # type: ignore[arg-type]
    return rollout.thetas


def adam_step(gradients: list[float], lr: float) -> float:
    """The last update of Adam (β 0.9/0.999, ε 1e-8) fed ``gradients``, from its definition."""
    m = v = 0.0
    for g in gradients:
        m = 0.9 * m + 0.1 * g
        v = 0.999 * v + 0.001 * g * g
    t = len(gradients)
    m_hat, v_hat = m / (1 - 0.9**t), v / (1 - 0.999**t)
    return -lr * m_hat / (v_hat**0.5 + 1e-8)


def test_a_restarted_adam_takes_a_fresh_first_step_at_the_reduced_rate() -> None:
    thetas = run(restart=True)
    first_after = thetas[REDUCTION_STEP + 2] - thetas[REDUCTION_STEP + 1]
    assert first_after == pytest.approx(adam_step([1.0], 0.005), rel=1e-9)  # = −0.005


def test_a_kept_adam_carries_its_moments_through_the_reduction() -> None:
    thetas = run(restart=False)
    first_after = thetas[REDUCTION_STEP + 2] - thetas[REDUCTION_STEP + 1]
    history = [1e-3] * (REDUCTION_STEP + 1) + [1.0]
    assert first_after == pytest.approx(adam_step(history, 0.005), rel=1e-9)
    assert abs(first_after) < 0.8 * 0.005  # measurably different from a restart


def test_restart_flag_must_be_boolean() -> None:
    with pytest.raises(ConfigError, match="optimizer.restart_adam_on_reduction"):
        PolicyOptimizer(restart_adam_on_reduction="yes")  # type: ignore[arg-type]


class HorizonRecordingRollout(LinearCostRollout):
    """:class:`LinearCostRollout` that records the horizon it is called with (as the
    optimiser sets it)."""

    def __init__(self, horizon: int) -> None:
        super().__init__()
        self.horizon = horizon
        self.horizons: list[int] = []
        self.dropouts: list[float] = []

    def __call__(self, particles: int, dropout: float, generator: object) -> _Cost:
        self.horizons.append(self.horizon)
        self.dropouts.append(dropout)
        return super().__call__(particles, dropout, generator)


def test_a_horizon_curriculum_shares_the_steps_among_growing_horizons() -> None:
    rollout = HorizonRecordingRollout(horizon=90)
    optimizer = PolicyOptimizer(
        num_particles=1,
        max_steps_first_trial=10,
        schedule={"window": 1000, "learning_rate_min": 1e-9},  # no early stop
        horizon_stages=[1 / 3, 0.5, 1.0],
    )
    result = optimizer.optimize(rollout, trial=1, generator=None)  # type: ignore[arg-type]
    # 10 steps over 3 stages: 3, 3 and the remaining 4; horizons ⌈90/3⌉, ⌈45⌉, 90.
    assert rollout.horizons == [30] * 3 + [45] * 3 + [90] * 4
    assert result.horizons == rollout.horizons
    assert rollout.horizon == 90  # restored
    assert rollout.dropouts == [0.25] * 3 + [0.0] * 7  # dropout in the first stage only
    # Each stage starts a fresh Adam: its first update is Adam's first step for that
    # step's gradient alone (1e-3 up to step REDUCTION_STEP, 1 after).
    updates = [b - a for a, b in zip(rollout.thetas[:-1], rollout.thetas[1:], strict=True)]
    for first in (3, 6):
        gradient = 1e-3 if first <= REDUCTION_STEP else 1.0
        assert updates[first] == pytest.approx(adam_step([gradient], 0.01), rel=1e-9)
    # ... which a continued Adam would not take at step 6 (its moments remember 1e-3).
    assert abs(adam_step([1e-3] * 4 + [1.0] * 3, 0.01)) < 0.9 * abs(updates[6])


def test_without_a_curriculum_the_whole_trial_uses_the_full_horizon() -> None:
    rollout = HorizonRecordingRollout(horizon=60)
    optimizer = PolicyOptimizer(num_particles=1, max_steps_first_trial=4)
    result = optimizer.optimize(rollout, trial=1, generator=None)  # type: ignore[arg-type]
    assert rollout.horizons == [60] * 4 and result.horizons == [60] * 4


@pytest.mark.parametrize(
    "stages", [[0.5], [0.5, 0.4, 1.0], [0.0, 1.0], [0.5, 1.5], [], "half", [0.5, 0.5, 1.0]]
)
def test_bad_horizon_stages_name_the_key(stages: object) -> None:
    with pytest.raises(ConfigError, match="optimizer.horizon_stages"):
        PolicyOptimizer(horizon_stages=stages)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("compiled_ms", "eager_ms", "eager_chosen"), [(90.0, 120.0, False), (500.0, 450.0, True)]
)
def test_compile_choice_keeps_whichever_the_first_steps_timed_faster(
    compiled_ms: float, eager_ms: float, eager_chosen: bool
) -> None:
    from types import SimpleNamespace

    from mcpilco.optim.compile_choice import CompileChoice

    compiler = SimpleNamespace(compile=True, choose_compile=True, eager_chosen=True)
    choice = CompileChoice(compiler, warmup=2, timed=3)  # type: ignore[arg-type]
    modes = []
    for step in range(12):
        choice.before(step)
        modes.append("eager" if compiler.eager_chosen else "compiled")
        choice.after(step, (eager_ms if compiler.eager_chosen else compiled_ms) / 1e3)
    # warm-up and timed compiled steps, timed eager steps, then the faster way for good
    assert modes[:8] == ["compiled"] * 5 + ["eager"] * 3
    assert modes[8:] == ["eager" if eager_chosen else "compiled"] * 4
    assert choice.decided and compiler.eager_chosen is eager_chosen


@pytest.mark.parametrize(
    ("compile", "choose"),
    [(False, False), (False, True), (True, False)],
    ids=["false", "false_auto", "true"],
)
def test_compile_choice_acts_only_on_compile_auto(compile: bool, choose: bool) -> None:
    """compile=false never compiles; compile=true always does (bit-for-bit reproducible)."""
    from types import SimpleNamespace

    from mcpilco.optim.compile_choice import CompileChoice

    compiler = SimpleNamespace(compile=compile, choose_compile=choose, eager_chosen=False)
    choice = CompileChoice(compiler)  # type: ignore[arg-type]
    for step in range(10):
        choice.before(step)
        choice.after(step, 1.0 if compiler.eager_chosen else 2.0)
    assert choice.decided and not compiler.eager_chosen and not choice.eager_seconds
