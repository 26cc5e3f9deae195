"""The torch.compile'd particle step against eager execution."""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from pathlib import Path

import pytest
import torch
import torch._dynamo
from hydra import compose, initialize_config_dir

from mcpilco.build import Experiment, build
from mcpilco.optim import PolicyOptimizer
from mcpilco.optim.policy_optimizer import frozen
from mcpilco.optim.rollout import ParticleRollout
from runners.bench import exploration_data

CONFIG_DIR = str(Path(__file__).resolve().parent.parent / "conf")
PARTICLES = 16


def small_experiment(*overrides: str) -> Experiment:
    with initialize_config_dir(version_base="1.3", config_dir=CONFIG_DIR):
        cfg = compose(
            "train",
            overrides=[
                *overrides,
                f"optimizer.num_particles={PARTICLES}",
                "policy.num_basis=10",
                "system.trial_duration=0.5",
            ],
        )
    return build(cfg)


def cost_and_gradient(
    rollout: ParticleRollout, dropout: float, seed: int
) -> tuple[float, torch.Tensor]:
    policy = rollout.policy
    policy.zero_grad()
    result = rollout(PARTICLES, dropout, torch.Generator().manual_seed(seed))
    result.total_cost.backward()
    gradient = torch.cat([p.grad.flatten() for p in policy.parameters()])  # type: ignore[union-attr]
    return float(result.total_cost.detach()), gradient


@pytest.mark.parametrize(
    "experiment",
    [
        ["rollout_dtype=null"],  # float64: the policy sees the particle (full state)
        pytest.param(  # float64, simulated readings (slow: its graphs compile)
            ["+experiment=cartpole_pms", "rollout_dtype=null"], marks=pytest.mark.slow
        ),
        pytest.param(  # float64 derivative-free histories (slow: CI time)
            ["+experiment=cartpole_df", "rollout_dtype=null"], marks=pytest.mark.slow
        ),
        [],  # the default, mixed setting (float32 rollout of a float64 GP)
        pytest.param(  # mixed, simulated readings, online low-pass estimator (slow: CI time)
            ["+experiment=cartpole_pms"], marks=pytest.mark.slow
        ),
    ],
    ids=["full_state", "pms", "derivative_free", "mixed", "mixed_pms"],
)
def test_compiled_rollout_matches_eager_through_dropout_changes_and_refits(
    experiment: list[str],
) -> None:
    """Same Ĵ and policy gradient as eager execution for every dropout of the schedule
    and after a refit on more data, with at most four compiled graphs (masked/unmasked ×
    fixed/dynamic data size): a fifth would hit the limit and fall back to eager."""
    torch._dynamo.reset()
    built = small_experiment(*experiment)
    c = built.components
    states, actions = exploration_data(built, 20)
    c.model.fit(states, actions)
    args = (c.system, c.model, c.policy, c.cost, c.estimator, c.simulate_estimator)
    eager = ParticleRollout.for_system(*args, dtype=c.rollout_dtype)
    compiled = ParticleRollout.for_system(*args, compile=True, dtype=c.rollout_dtype)
    # float32 rounding differs between fused and unfused kernels by ~1e-7 per operation
    rel_cost, rel_gradient, abs_gradient = (
        (1e-7, 1e-5, 1e-8) if c.rollout_dtype is None else (1e-4, 1e-3, 1e-6)
    )
    settings = [(0.25, 0), (0.25, 1), (0.125, 0), (0.0, 0), ("refit", 0), (0.25, 2), (0.0, 2)]
    settings.append(("no_grad", 0))  # a gradient-free rollout (the loggers'): eager, no graph
    with torch._dynamo.config.patch(recompile_limit=4, fail_on_recompile_limit_hit=True):
        for dropout, seed in settings:
            if dropout == "refit":
                states, actions = exploration_data(built, 40, seed=5)
                c.model.fit(states, actions)
                continue
            if dropout == "no_grad":
                with torch.no_grad():
                    expected = eager(PARTICLES, 0.0, torch.Generator().manual_seed(seed))
                    got = compiled(PARTICLES, 0.0, torch.Generator().manual_seed(seed))
                assert float(got.total_cost) == float(expected.total_cost)  # both eager
                assert compiled.compiler.compile  # it did not try (and fail) to compile a graph
                continue
            with frozen(c.model):
                cost, gradient = cost_and_gradient(eager, float(dropout), seed)
                cost_compiled, gradient_compiled = cost_and_gradient(compiled, float(dropout), seed)
            # Rounding only: the posterior variance λ² − k*Γ⁻¹k*ᵀ cancels to a few digits,
            # so a reordered sum shifts it by ~1e-9 relative (a missing term or a wrong
            # mask moves Ĵ by percent).
            assert cost_compiled == pytest.approx(cost, rel=rel_cost)
            torch.testing.assert_close(
                gradient_compiled, gradient, rtol=rel_gradient, atol=abs_gradient
            )
            assert compiled.compiler.compile  # never fell back to eager


def test_a_failing_compiler_falls_back_to_eager_with_a_warning(
    caplog: pytest.LogCaptureFixture,
) -> None:
    experiment = small_experiment()
    c = experiment.components
    states, actions = exploration_data(experiment, 20)
    c.model.fit(states, actions)
    rollout = ParticleRollout.for_system(
        c.system, c.model, c.policy, c.cost, c.estimator, compile=True
    )
    rollout.compiler.compile = False
    with frozen(c.model):
        reference = cost_and_gradient(rollout, 0.25, 0)

    def broken(*args: object) -> torch.Tensor:
        raise RuntimeError("no C++ compiler")

    rollout.compiler.compile = True
    rollout.compiler._compiled["_steps"] = broken
    with caplog.at_level(logging.WARNING), frozen(c.model):
        cost, gradient = cost_and_gradient(rollout, 0.25, 0)
    assert "running eagerly" in caplog.text and "no C++ compiler" in caplog.text
    assert not rollout.compiler.compile
    assert cost == reference[0]
    torch.testing.assert_close(gradient, reference[1], rtol=0, atol=0)


@pytest.mark.slow  # CI time (make test-slow runs it)
def test_a_new_compiling_rollout_is_not_limited_by_the_graphs_of_an_earlier_run() -> None:
    """A sweep's jobs or the bench's settings run one after another in a process; each
    run's rollout starts with PyTorch's compile caches cleared, so the graphs of earlier
    runs do not use up the per-function limit (which would silently run eagerly)."""
    with torch._dynamo.config.patch(recompile_limit=2, fail_on_recompile_limit_hit=True):
        for overrides in ([], ["dtype=float32"], ["kernel=sp"]):
            built = small_experiment(*overrides)
            c = built.components
            states, actions = exploration_data(built, 20)
            c.model.fit(states, actions)
            rollout = ParticleRollout.for_system(
                c.system,
                c.model,
                c.policy,
                c.cost,
                c.estimator,
                c.simulate_estimator,
                compile=True,
            )
            with frozen(c.model):
                cost_and_gradient(rollout, 0.25, 0)
            assert rollout.compiler.compile, overrides


def test_refits_of_a_run_never_use_up_the_graph_limit() -> None:
    """Each fit brings GP tensors of a new size and its own masked and unmasked graphs; a
    run of many trials must not reach PyTorch's per-function graph limit (after which it
    runs eagerly, silently: seen at trial 5 of a cart-pole run). Here the limit is 2, one
    fit's worth, and a second fit follows."""
    with torch._dynamo.config.patch(recompile_limit=2, fail_on_recompile_limit_hit=True):
        built = small_experiment()
        c = built.components
        args = (c.system, c.model, c.policy, c.cost, c.estimator, c.simulate_estimator)
        rollout = ParticleRollout.for_system(*args, compile=True, dtype=c.rollout_dtype)
        for size in (20, 30):
            states, actions = exploration_data(built, size, seed=size)
            c.model.fit(states, actions)
            with frozen(c.model):
                for dropout in (0.25, 0.0):
                    cost, _ = cost_and_gradient(rollout, dropout, 0)
                    assert math.isfinite(cost)
            assert rollout.compiler.compile, size  # never fell back to eager


class _FailingBackward(torch.autograd.Function):
    """Identity forward; a backward that fails as a corrupt compiled kernel does."""

    @staticmethod
    def forward(ctx: object, particles: torch.Tensor) -> torch.Tensor:
        return particles.view_as(particles)

    @staticmethod
    def backward(ctx: object, grad: torch.Tensor) -> torch.Tensor:
        raise ImportError("cache/kernel.main.so: file too short")


def _failing_backward(
    steps: Callable[..., tuple[tuple[torch.Tensor, ...], list[torch.Tensor]]],
) -> Callable[..., tuple[tuple[torch.Tensor, ...], list[torch.Tensor]]]:
    def run(*args: object) -> tuple[tuple[torch.Tensor, ...], list[torch.Tensor]]:
        carry, states = steps(*args)
        return carry, [_FailingBackward.apply(state) for state in states]

    return run


def test_a_backward_that_fails_to_compile_replays_the_step_eagerly(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """The backward graphs compile at the first backward pass, outside the forward's
    fallback; a failure there (seen with a kernel cache truncated by a killed run) must
    not end the run: the step is replayed eagerly with the same draws, so the policy ends
    exactly where an eager optimisation takes it."""
    experiment = small_experiment()
    c = experiment.components
    states, actions = exploration_data(experiment, 20)
    c.model.fit(states, actions)
    schedule = {"window": 200, "threshold": 0.08, "dropout_step": 0.125, "learning_rate": 0.01}
    initial = {k: v.clone() for k, v in c.policy.state_dict().items()}
    final = []
    for compiled in (False, True):
        c.policy.load_state_dict(initial)
        rollout = ParticleRollout.for_system(
            c.system, c.model, c.policy, c.cost, c.estimator, compile=compiled
        )
        if compiled:
            rollout.compiler._compiled["_steps"] = _failing_backward(rollout._steps)
        optimizer = PolicyOptimizer(
            num_particles=PARTICLES, max_steps=3, max_steps_first_trial=3, schedule=schedule
        )
        with caplog.at_level(logging.WARNING):
            result = optimizer.optimize(
                rollout, trial=1, generator=torch.Generator().manual_seed(3)
            )
        assert result.steps == 3
        final.append(torch.cat([p.detach().flatten() for p in c.policy.parameters()]))
    assert "file too short" in caplog.text and "running eagerly" in caplog.text
    assert not rollout.compiler.compile
    torch.testing.assert_close(final[1], final[0], rtol=0, atol=0)


@pytest.mark.parametrize(
    "experiment",
    [
        pytest.param(["rollout_dtype=null"], id="state"),
        pytest.param(  # slow: CI time
            ["+experiment=cartpole_pms", "rollout_dtype=null"],
            id="readings",
            marks=pytest.mark.slow,
        ),
    ],
)
def test_several_time_steps_per_compiled_call_give_the_one_step_rollout(
    experiment: list[str],
) -> None:
    """A 10- or 15-step rollout run 4 steps per call (the first one or two steps eager,
    then chunks of 4 and a shorter last one) gives, eagerly, exactly the numbers of one
    step per call, and compiled the eager Ĵ and gradient to rounding."""
    torch._dynamo.reset()
    built = small_experiment(*experiment)
    c = built.components
    horizon = c.system.num_steps
    states, actions = exploration_data(built, 20)
    c.model.fit(states, actions)
    args = (c.system, c.model, c.policy, c.cost, c.estimator, c.simulate_estimator)
    one = ParticleRollout.for_system(*args, dtype=c.rollout_dtype)
    chunked = ParticleRollout.for_system(*args, dtype=c.rollout_dtype, compile_steps=4)
    compiled = ParticleRollout.for_system(
        *args, compile=True, dtype=c.rollout_dtype, compile_steps=4
    )
    with frozen(c.model):
        cost, gradient = cost_and_gradient(one, 0.25, 0)
        cost_chunked, gradient_chunked = cost_and_gradient(chunked, 0.25, 0)
        cost_compiled, gradient_compiled = cost_and_gradient(compiled, 0.25, 0)
        states_one = one(PARTICLES, 0.0, torch.Generator().manual_seed(1)).states
        states_chunked = chunked(PARTICLES, 0.0, torch.Generator().manual_seed(1)).states
    assert cost_chunked == cost
    torch.testing.assert_close(gradient_chunked, gradient, rtol=0, atol=0)
    torch.testing.assert_close(states_chunked, states_one, rtol=0, atol=0)
    assert states_one.shape == (horizon + 1, PARTICLES, c.system.state_dim)
    assert cost_compiled == pytest.approx(cost, rel=1e-7)
    torch.testing.assert_close(gradient_compiled, gradient, rtol=1e-5, atol=1e-8)
    assert compiled.compiler.compile  # never fell back to eager
