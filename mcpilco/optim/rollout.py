"""Monte Carlo particle rollout through the GP model (thesis §2.4.2, Fig. 3.2)."""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import torch
from torch import nn

from mcpilco.estimators.base import StateEstimator
from mcpilco.models.base import ModelStructure
from mcpilco.optim.step_compiler import StepCompiler
from mcpilco.policies.rbf import SquashedRBFPolicy
from mcpilco.systems.base import MechanicalSystem
from mcpilco.systems.sensors import Sensors

log = logging.getLogger(__name__)


@dataclass
class RolloutResult:
    """Ĵ (scalar, differentiable), mean cost per step ``[T+1]`` and states ``[T+1, M, d_x]``."""

    total_cost: torch.Tensor
    step_costs: torch.Tensor
    states: torch.Tensor


class ParticleRollout:
    """Propagates M particles from p(x0) for T steps under a policy.

    Per step: the online estimator turns a simulated sensor reading of each particle
    (fictitious Gaussian and quantisation noise, thesis §3.2, §4.1) into what the policy
    sees (for a derivative-free model: the history of simulated readings) — with full-state
    measurement and a state-based model the policy sees the particle itself — the policy acts
    (with a fresh dropout mask per particle and step), the model samples the
    next particle with pre-drawn standard-normal noise (reparameterisation trick). All
    random numbers of a rollout are drawn up front in a few batched calls.

    Args:
        model: fitted model structure. policy: the policy being optimised.
        cost: c(x) on states ``[..., d_x]``. estimator: online estimator.
        initial_mean, initial_std: p(x0) = N(mean, diag(std²)), ``[d_x]`` each.
        horizon: T.
        initial_uniform: p(x0) uniform on mean ± std instead (each standard-normal draw z
            becomes erf(z/√2), uniform on (−1, 1)).
        sensors: the system's sensors, simulated on the particles for a non-identity
            estimator (None: the policy sees the particle itself).
        compile: run each time step of a rollout that records gradients (features or
            simulated readings and online estimate, policy, GP sample, transition, and
            their backward) through ``torch.compile``: fused kernels instead of ~80 small
            ops per step. Compiles a few graphs
            (seconds each, cached on disk by PyTorch) and falls back to eager execution,
            with a warning, where compilation fails (e.g. no C++ compiler on a CPU-only
            machine). Results agree with eager execution to rounding. ``"auto"``: compile,
            and let the policy search time its first steps both ways and keep the faster
            (:class:`~mcpilco.optim.compile_choice.CompileChoice`); the run is then
            reproducible only up to rounding. Held by :attr:`compiler`
            (:class:`~mcpilco.optim.step_compiler.StepCompiler`).
        compile_steps: time steps per compiled call (one graph runs that many steps and
            their backward): fewer calls, guard checks and autograd nodes per rollout.
            The numbers are those of one step per call up to rounding.
        dtype: the particles' dtype (None: the policy's). ``float32`` with a float64 model
            and policy is the mixed setting (``rollout_dtype=float32``): the GP stays fitted
            and factorised in float64, the rollout (features, policy, cross-covariances,
            GP sample and their backward) runs in float32 with the whitened variance
            (:mod:`mcpilco.gp.prediction`), the cost is summed in float64, and the gradient
            reaches the float64 policy parameters.
    """

    def __init__(
        self,
        model: ModelStructure,
        policy: SquashedRBFPolicy,
        cost: nn.Module,
        estimator: StateEstimator,
        initial_mean: torch.Tensor,
        initial_std: torch.Tensor,
        horizon: int,
        sensors: Sensors | None = None,
        initial_uniform: bool = False,
        compile: bool | str = False,
        dtype: torch.dtype | None = None,
        compile_steps: int = 1,
    ) -> None:
        self.initial_uniform = initial_uniform
        self.compiler = StepCompiler(compile, compile_steps)
        self.sensors = sensors
        self.model = model
        self.policy = policy
        self.cost = cost
        self.estimator = estimator
        self.result_dtype = initial_mean.dtype
        self.requested_dtype = initial_mean.dtype if dtype is None else dtype
        self.dtype = self.requested_dtype  # this GP's: the model's where it cannot (below)
        self.initial_mean = initial_mean
        self.initial_std = initial_std
        self.horizon = horizon
        self._twin: ModelStructure | None = None
        self._checked_gp: object = None

    @classmethod
    def for_system(
        cls,
        system: MechanicalSystem,
        model: ModelStructure,
        policy: SquashedRBFPolicy,
        cost: nn.Module,
        estimator: StateEstimator,
        simulate_estimator: bool = True,
        compile: bool | str = False,
        dtype: torch.dtype | None = None,
        compile_steps: int = 1,
    ) -> ParticleRollout:
        """A rollout from the system's p(x0) over its search horizon (one trial unless the
        system says otherwise, :attr:`MechanicalSystem.search_steps`), on the policy's device, in
        ``dtype`` (None: the policy's); with ``simulate_estimator`` false the policy sees
        the particles instead of online estimates of their simulated readings (MC-PILCO
        instead of MC-PILCO4PMS); ``compile``, ``dtype``, ``compile_steps``: see the class."""
        like = next(policy.parameters())
        return cls(
            model=model,
            policy=policy,
            cost=cost,
            estimator=estimator,
            initial_mean=torch.as_tensor(system.initial_mean, dtype=like.dtype, device=like.device),
            initial_std=torch.as_tensor(system.initial_std, dtype=like.dtype, device=like.device),
            horizon=system.search_steps,
            sensors=system.sensors if simulate_estimator else None,
            initial_uniform=system.initial_distribution == "uniform",
            compile=compile,
            dtype=dtype,
            compile_steps=compile_steps,
        )

    def __call__(
        self,
        num_particles: int,
        dropout: float,
        generator: torch.Generator | None,
        act: Callable[..., torch.Tensor] | None = None,
        copies: int = 1,
    ) -> RolloutResult:
        """Simulate ``num_particles`` particles (``copies`` × that many with ``copies`` > 1:
        the same random numbers repeated for each copy, block after block, e.g. one block
        per candidate policy of a population, which ``act`` then tells apart; dropout is
        not allowed then). ``act``: the policy's ``prepare(dropout)`` unless given."""
        model = self.stepping_model()  # first: it settles the dtype for this GP
        self.compiler.forget_graphs_of_earlier_fits(self.model.gp)
        # drawn in the model's dtype and cast: a float32 rollout sees the float64 one's numbers
        like = {"dtype": self.result_dtype, "device": self.initial_mean.device}
        dim = self.initial_mean.shape[0]
        if copies > 1 and dropout > 0:
            raise ValueError("a rollout with copies > 1 takes no dropout")
        start = torch.randn(num_particles, dim, generator=generator, **like).to(self.dtype)
        noise = torch.randn(
            self.horizon, self.model.num_outputs, num_particles, generator=generator, **like
        ).to(self.dtype)
        bits = (
            self.policy.dropout_bits(self.horizon, num_particles, generator)
            if dropout > 0
            else None
        )
        readings = self._reading_noise(num_particles, generator, like)
        if copies > 1:
            start, noise = start.repeat(copies, 1), noise.repeat(1, 1, copies)
            if readings is not None:
                gaussian, uniform = readings
                readings = (
                    gaussian.repeat(1, copies, 1),
                    None if uniform is None else uniform.repeat(1, copies, 1),
                )
            num_particles *= copies
        act = self.policy.prepare(dropout, self.dtype) if act is None else act
        particles = model.initial_particles(self.initial_states(start))
        states = [model.physical_state(particles)]
        carry: tuple[Any, ...] = (particles,)
        per_step: tuple[torch.Tensor | None, ...] = (bits, noise)
        eager_steps = 1  # the first step eager: its particles need no gradient (a graph fewer)
        if readings is not None:
            memory = self.estimator.online_reset(num_particles, particles)
            carry = (particles, memory, None, None)  # + what the policy read, actions
            per_step = (*readings, bits, noise)
            eager_steps = 2  # no history yet, then one without gradients
        for first, last, compiled in self.compiler.chunks(self.horizon, eager_steps):
            sliced = tuple(None if x is None else x[first:last] for x in per_step)
            carry, new_states = self.compiler.run(
                self._steps, compiled, readings is not None, act, carry, sliced, first
            )
            states.extend(new_states)
        trajectory = torch.stack(states).to(self.result_dtype)  # [T+1, M, d_x]
        step_costs = self.cost(trajectory).mean(-1)  # [T+1]
        return RolloutResult(step_costs.sum(), step_costs, trajectory)

    def stepping_model(self) -> ModelStructure:
        """The model the particles go through: :attr:`model` itself, or its twin in the
        rollout's dtype (kept across trials, its GP re-pointed after each fit, so compiled
        graphs see one object). A GP whose predictions are not finite in the requested
        dtype (:meth:`ExactGP.predicts_in`) is rolled out in the model's own, with a
        warning, until the next fit."""
        gp = self.model.gp
        if self.requested_dtype != self.result_dtype and gp is not self._checked_gp:
            self._checked_gp = gp
            fits = gp is None or gp.predicts_in(self.requested_dtype)
            self.dtype = self.requested_dtype if fits else self.result_dtype
            if not fits:
                log.warning(
                    "the GP's predictions are not finite in %s (hyper-parameters out of its "
                    "range); rolling out in %s until the next fit",
                    self.requested_dtype,
                    self.result_dtype,
                )
        if self.dtype == self.result_dtype:
            return self.model
        if self._twin is None:
            self._twin = self.model.in_dtype(self.dtype)
        if self._twin.gp is not self.model.gp:
            self._twin.gp = self.model.gp
        return self._twin

    def _steps(
        self,
        reads: bool,
        act: Callable[..., torch.Tensor],
        carry: tuple[Any, ...],
        per_step: tuple[torch.Tensor | None, ...],
        first: int,
    ) -> tuple[tuple[Any, ...], list[torch.Tensor]]:
        """Time steps ``first``, ``first`` + 1, … of a rollout, one per entry of the
        per-step draws ``per_step`` (each ``[k, ...]`` or None; noise last, never None):
        ``carry`` is (particles,) or, with simulated readings (``reads``), (particles,
        estimator memory, what the policy read, actions). Returns the new carry and the
        physical states ``[M, d_x]`` after each step."""
        model = self.stepping_model()
        states = []
        for j in range(per_step[-1].shape[0]):  # type: ignore[union-attr]
            draws = (None if x is None else x[j] for x in per_step)
            # ``first`` passed on untouched where it can be: arithmetic on an int input makes
            # the compiler guard on it (a graph more), which a model that ignores the step
            # index (no tracking reference) would pay for nothing
            step = first if j == 0 else first + j
            if reads:
                carry = self._reading_step(act, *carry, *draws, step)
            else:
                carry = (self._state_step(act, *carry, *draws, step),)
            states.append(model.physical_state(carry[0]))
        return carry, states

    def _state_step(
        self,
        act: Callable[..., torch.Tensor],
        particles: torch.Tensor,
        bits: torch.Tensor | None,
        noise: torch.Tensor,
        step: int,
    ) -> torch.Tensor:
        """Next particles ``[M, S]`` when the policy sees the particle itself: its features
        are encoded once for both the policy and the GP input. ``bits`` ``[M, n_b]`` (or
        None), ``noise`` ``[G, M]``."""
        model = self.stepping_model()
        encoded = model.encode(particles)
        policy_inputs = model.policy_inputs_from_encoded(encoded)
        policy_inputs = model.with_tracking_errors(
            policy_inputs, model.physical_state(particles), step
        )
        actions = act(policy_inputs, bits)
        return model.step(particles, actions, noise, encoded)

    def _reading_step(
        self,
        act: Callable[..., torch.Tensor],
        particles: torch.Tensor,
        memory: Any,
        seen: torch.Tensor | None,
        actions: torch.Tensor | None,
        gaussian: torch.Tensor,
        uniform: torch.Tensor | None,
        bits: torch.Tensor | None,
        noise: torch.Tensor,
        step: int,
    ) -> tuple[torch.Tensor, Any, torch.Tensor, torch.Tensor]:
        """Next (particles, estimator memory, what the policy read, actions ``[M, d_u]``)
        when the policy sees online estimates of simulated readings: the particles are read
        with fictitious noise (``gaussian`` ``[M, d_y]``, quantisation ``uniform``), the
        estimator steps, the policy acts on the estimate (a history for DF models)."""
        assert self.sensors is not None
        model = self.stepping_model()
        reading = self.sensors.simulate(model.physical_state(particles), gaussian, uniform)
        estimate, memory = self.estimator.online_step(reading, memory)
        seen = model.closed_loop_state(seen, estimate, actions)
        policy_inputs = model.with_tracking_errors(model.policy_inputs(seen), estimate, step)
        actions = act(policy_inputs, bits)
        return model.step(particles, actions, noise), memory, seen, actions

    def initial_states(self, standard_normal: torch.Tensor) -> torch.Tensor:
        """Samples of p(x0) ``[M, d_x]`` from standard-normal draws ``[M, d_x]``."""
        if self.initial_uniform:
            standard_normal = torch.special.erf(standard_normal * math.sqrt(0.5))
        dtype = standard_normal.dtype
        return self.initial_mean.to(dtype) + self.initial_std.to(dtype) * standard_normal

    def _reading_noise(
        self, num_particles: int, generator: torch.Generator | None, like: dict[str, Any]
    ) -> tuple[torch.Tensor, torch.Tensor | None] | None:
        """Standard-normal ``[T, M, d_y]`` and U(0,1) ``[T, M, d_y]`` (only if quantised)
        draws for the simulated readings; None when the policy sees the particle itself
        (identity estimator and a state-based model, or sensors not simulated)."""
        if self.sensors is None or (self.estimator.is_identity and not self.model.sees_readings):
            return None
        shape = (self.horizon, num_particles, self.sensors.reading_dim)
        gaussian = torch.randn(shape, generator=generator, **like).to(self.dtype)
        if not self.sensors.quantised:
            return gaussian, None
        return gaussian, torch.rand(shape, generator=generator, **like).to(self.dtype)
