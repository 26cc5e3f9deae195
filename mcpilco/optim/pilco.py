"""PILCO's policy search: L-BFGS on the moment-matched expected cost (Deisenroth &
Rasmussen 2011), in the same trial loop as MC-PILCO."""

from __future__ import annotations

import copy
import logging
import math
from collections.abc import Callable

import torch

from mcpilco.errors import ConfigError
from mcpilco.kernels.se import SquaredExponential
from mcpilco.models.full_state import FullState
from mcpilco.moments.propagation import MomentMatchingRollout, initial_covariance
from mcpilco.optim.base import (
    OptimizationResult,
    PolicySearch,
    StepInfo,
    require_positive_integers,
)
from mcpilco.optim.policy_optimizer import frozen
from mcpilco.optim.rollout import ParticleRollout

log = logging.getLogger(__name__)


class PilcoSearch(PolicySearch):
    """Minimises J = Σ_{t=0}^{T} E c(x_t) with x_t's Gaussian from
    :class:`~mcpilco.moments.propagation.MomentMatchingRollout`, by L-BFGS (strong-Wolfe
    line search) on its analytic gradient (autograd through the closed-form moments).

    Its trace has one entry per objective evaluation with a finite J (``cost``; line-search
    trial points included; ``learning_rate`` and ``signal`` NaN).

    Needs ``model=full_state`` with ``kernel=se`` (PILCO's model), ``policy.squash=sine``
    (PILCO's saturation), a cost with a closed-form Gaussian expectation
    (``cost=cartpole_pilco``) and no tracking reference; :meth:`check` refuses anything else.

    Args:
        max_iterations: L-BFGS iterations per trial (PILCO's cart-pole: 150 line searches).
        max_evaluations: objective evaluations per trial (None: 1.25 × max_iterations).
        history_size: L-BFGS memory.
        num_particles: particles of the final policy's prediction for the loggers and the
            calibration figures (the search itself uses none).
        initialisation: ``pilco`` re-draws the policy before trial 1 as PILCO's cart-pole
            scenario does: centres where the system starts (states from N(x̄0, 0.1² I), PILCO's
            start distribution, mapped to the policy input x*), small outputs (weights
            N(0, (0.1 u_max)²/n_b), so the network's pre-saturation output is ≈ 0.1 N(0, 1)
            near x0, as PILCO's pseudo-targets 0.1 N(0, 1)); ``policy`` keeps the policy
            group's initialisation (MC-PILCO's: centres over ±centre_range, weights
            U(±u_max/2)), under which the expected cost starts flat (activations ≈ e⁻¹⁶
            near x0) and L-BFGS often stops at once (measured: README).
    """

    def __init__(
        self,
        max_iterations: int = 150,
        max_evaluations: int | None = None,
        history_size: int = 100,
        num_particles: int = 400,
        initialisation: str = "pilco",
    ) -> None:
        if initialisation not in ("pilco", "policy"):
            raise ConfigError(
                f"optimizer.initialisation must be pilco or policy, got {initialisation!r}"
            )
        self.initialisation = initialisation
        require_positive_integers(
            max_iterations=max_iterations, history_size=history_size, num_particles=num_particles
        )
        if max_evaluations is not None:
            require_positive_integers(max_evaluations=max_evaluations)
        self.max_iterations = max_iterations
        self.max_evaluations = max_evaluations or math.ceil(1.25 * max_iterations)
        self.history_size = history_size
        self.num_particles = num_particles

    def check(self, rollout: ParticleRollout) -> None:
        model, policy, cost = rollout.model, rollout.policy, rollout.cost
        if not isinstance(model, FullState):
            raise ConfigError(
                "algorithm=pilco needs model=full_state (PILCO's model, one GP per state "
                f"component), got model={type(model).__name__}"
            )
        kernel = model.new_gp().kernel
        if type(kernel) is not SquaredExponential or kernel.active_dims is not None:
            raise ConfigError(
                "algorithm=pilco needs kernel=se (moment matching is closed-form for the SE "
                f"kernel on all inputs), got kernel={type(kernel).__name__}"
            )
        if not callable(getattr(policy, "gaussian_moments", None)) or (
            getattr(policy, "squash", "sine") != "sine"
        ):
            raise ConfigError(
                "algorithm=pilco needs policy.squash=sine (PILCO's saturation, closed-form "
                f"moments), got policy.squash={getattr(policy, 'squash', None)!r}"
            )
        if not callable(getattr(cost, "expected_gaussian", None)):
            raise ConfigError(
                "algorithm=pilco needs a cost with a closed-form Gaussian expectation "
                f"(e.g. cost=cartpole_pilco), got cost={type(cost).__name__}"
            )
        try:
            cost.expected_gaussian(
                rollout.initial_mean,
                initial_covariance(rollout.initial_std, rollout.initial_uniform),
            )
        except (RuntimeError, IndexError) as error:
            raise ConfigError(
                f"cost={type(cost).__name__} cannot be evaluated on this system's state: {error}"
            ) from None
        if model.policy_input_size != model.policy_input_dim:
            raise ConfigError(
                "algorithm=pilco does not support tracking tasks (policy inputs with a "
                f"reference), got system={type(model.system).__name__}"
            )
        if rollout.sensors is not None and not (
            rollout.estimator.is_identity and not model.sees_readings
        ):
            raise ConfigError(
                "algorithm=pilco propagates the state itself: it needs estimator=none with "
                "the full state measured (or simulate_estimator=false)"
            )

    @torch.no_grad()
    def initialise_policy(
        self, rollout: ParticleRollout, generator: torch.Generator | None
    ) -> None:
        """PILCO's initial policy (see ``initialisation``)."""
        policy, model = rollout.policy, rollout.model
        like = {"dtype": rollout.initial_mean.dtype, "device": rollout.initial_mean.device}
        count = policy.num_basis
        noise = torch.randn(count, rollout.initial_mean.shape[0], generator=generator, **like)
        policy.centres.copy_(model.encode(rollout.initial_mean + 0.1 * noise))
        weights = torch.randn(policy.weights.shape, generator=generator, **like)
        policy.weights.copy_(weights * 0.1 * policy.u_max / count**0.5)

    def predictor(self, rollout: ParticleRollout) -> MomentMatchingRollout:
        """The moment-matching rollout of ``rollout``'s model, policy, cost and p(x0)."""
        return MomentMatchingRollout(
            rollout.model,
            rollout.policy,
            rollout.cost,
            rollout.initial_mean,
            initial_covariance(rollout.initial_std, rollout.initial_uniform),
            rollout.horizon,
        )

    def step_budget(self, trial: int) -> int:
        """At most ``max_evaluations`` objective evaluations (one ``on_step`` each)."""
        return self.max_evaluations

    def optimize(
        self,
        rollout: ParticleRollout,
        trial: int,
        generator: torch.Generator | None,
        on_step: Callable[[StepInfo], None] | None = None,
    ) -> OptimizationResult:
        """L-BFGS for at most ``max_iterations`` iterations; the policy ends at the best
        evaluated point (a line search may try non-finite or worse points)."""
        policy = rollout.policy  # components checked by build() (self.check)
        if trial == 1 and self.initialisation == "pilco":
            self.initialise_policy(rollout, generator)
        predict = self.predictor(rollout)
        parameters = [p for p in policy.parameters() if p.requires_grad]
        optimizer = torch.optim.LBFGS(
            parameters,
            lr=1.0,
            max_iter=self.max_iterations,
            max_eval=self.max_evaluations,
            history_size=self.history_size,
            tolerance_grad=1e-9,
            tolerance_change=1e-12,
            line_search_fn="strong_wolfe",
        )
        result = OptimizationResult()
        best = {"cost": math.inf, "state": copy.deepcopy(policy.state_dict())}

        def closure() -> torch.Tensor:
            optimizer.zero_grad(set_to_none=True)
            total = predict().total_cost
            cost = float(total.detach())
            if not math.isfinite(cost):
                # a line-search trial point out of the finite numbers: report it as +big
                # with no gradient so the search backs off
                return torch.tensor(1e10, dtype=total.dtype, device=total.device)
            total.backward()
            if cost < best["cost"]:
                best["cost"] = cost
                best["state"] = copy.deepcopy(policy.state_dict())
            info = StepInfo(result.steps, cost, 0.0, math.nan, math.nan, rollout.horizon)
            result.append(info)
            if on_step is not None:
                on_step(info)
            return total

        with frozen(rollout.model):
            try:
                optimizer.step(closure)
            except (RuntimeError, torch.linalg.LinAlgError) as error:  # e.g. a Cholesky
                log.warning("trial %d: PILCO's L-BFGS stopped: %s", trial, error)
        if math.isfinite(best["cost"]):
            policy.load_state_dict(best["state"])
        return result
