"""Black-DROPS's policy search: CMA-ES on the particle estimate of the expected cost
(Chatzilygeroudis et al. 2017), in the same trial loop as MC-PILCO."""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import torch
from torch.nn.utils import parameters_to_vector, vector_to_parameters

from mcpilco.errors import ConfigError
from mcpilco.optim.base import (
    OptimizationResult,
    PolicySearch,
    StepInfo,
    require_positive_integers,
)
from mcpilco.optim.rollout import ParticleRollout

log = logging.getLogger(__name__)

GRADIENT_ONLY_OPTIONS = (
    "schedule",
    "max_steps",
    "max_steps_first_trial",
    "max_nan_retries",
    "restart_adam_on_reduction",
    "horizon_stages",
    "learning_rate",
    "dropout",
)


class BlackDropsSearch(PolicySearch):
    """BIPOP-CMA-ES (``cma.fmin2``) over the policy's parameter vector, minimising
    Ĵ = Σ_t mean_m c(x_t^(m)) on M particles through the GP model, without gradients.

    A generation's candidates are evaluated in one rollout of P × M particles (block p
    driven by candidate p) with common random numbers: every candidate of a generation sees
    the same particle noise, fresh each generation, so CMA-ES ranks candidates on the
    same draws (Black-DROPS instead relies on CMA-ES's uncertainty handling; a variance
    reduction of ours). The search starts at the current policy and ends at the best
    candidate evaluated. Its trace has one entry per generation: ``cost`` the generation's
    mean Ĵ, ``signal`` its best Ĵ (``learning_rate`` NaN, ``dropout`` 0).

    Args:
        num_particles: M per policy evaluation.
        max_evaluations: policy evaluations per trial over all restarts.
        population: CMA-ES population (None: the package's 4 + 3 ln n).
        sigma: initial step size, in units of each parameter's scale (centres: their
            initial range; weights: u_max / 2; log length-scales: 1).
        restarts: BIPOP restarts.
        **options: any other key is refused; gradient-search keys (schedule, dropout,
            max_steps, ...) with an error that says so.
    """

    def __init__(
        self,
        num_particles: int = 400,
        max_evaluations: int = 10000,
        population: int | None = None,
        sigma: float = 0.5,
        restarts: int = 3,
        **options: Any,
    ) -> None:
        for key in options:
            if key in GRADIENT_ONLY_OPTIONS:
                raise ConfigError(
                    f"optimizer.{key} is an option of gradient-based policy search; "
                    "algorithm=blackdrops (CMA-ES) has none"
                )
            raise ConfigError(f"optimizer.{key} is not an option of algorithm=blackdrops")
        require_positive_integers(num_particles=num_particles, max_evaluations=max_evaluations)
        if population is not None and (not isinstance(population, int) or population < 2):
            raise ConfigError(f"optimizer.population must be >= 2 or null, got {population!r}")
        if not sigma > 0:
            raise ConfigError(f"optimizer.sigma must be > 0, got {sigma!r}")
        if not isinstance(restarts, int) or restarts < 0:
            raise ConfigError(f"optimizer.restarts must be >= 0, got {restarts!r}")
        self.num_particles = num_particles
        self.max_evaluations = max_evaluations
        self.population = population
        self.sigma = float(sigma)
        self.restarts = restarts

    def check(self, rollout: ParticleRollout) -> None:
        if not callable(getattr(rollout.policy, "population_act", None)):
            raise ConfigError(
                "algorithm=blackdrops needs a policy with population_act (batched candidate "
                f"evaluation), got policy={type(rollout.policy).__name__}"
            )

    def evaluate(
        self, rollout: ParticleRollout, vectors: torch.Tensor, generator: torch.Generator | None
    ) -> torch.Tensor:
        """Ĵ ``[P]`` of P parameter vectors ``[P, n]`` on M particles each (common random
        numbers), without gradients."""
        count = vectors.shape[0]
        with torch.no_grad():
            act = rollout.policy.population_act(vectors)
            result = rollout(self.num_particles, 0.0, generator, act=act, copies=count)
            costs = rollout.cost(result.states)  # [T+1, P·M]
            return costs.view(costs.shape[0], count, -1).mean(-1).sum(0)

    def scales(self, rollout: ParticleRollout) -> np.ndarray:
        """Each parameter's scale ``[n]``, in the order of ``parameters()``."""
        parts = []
        policy = rollout.policy
        for name, parameter in policy.named_parameters():
            if name == "centres":
                ranges = policy.centre_range.to(device="cpu", dtype=torch.float64)
                value = ranges.expand(parameter.shape) if ranges.dim() else ranges
                parts.append(torch.broadcast_to(value, parameter.shape).flatten())
            elif name == "weights":
                parts.append(torch.full((parameter.numel(),), policy.u_max / 2.0))
            else:
                parts.append(torch.ones(parameter.numel()))
        return torch.cat([p.to(torch.float64) for p in parts]).numpy()

    def optimize(
        self,
        rollout: ParticleRollout,
        trial: int,
        generator: torch.Generator | None,
        on_step: Callable[[StepInfo], None] | None = None,
    ) -> OptimizationResult:
        policy = rollout.policy  # components checked by build() (self.check)
        start = parameters_to_vector(policy.parameters()).detach()
        like = {"dtype": start.dtype, "device": start.device}
        result = OptimizationResult()
        state = {"evaluations": 0, "best": math.inf, "best_vector": start.clone()}
        seed = int(torch.randint(1, 2**31 - 1, (1,), generator=generator).item())

        def objective(candidates: Sequence[np.ndarray]) -> list[float]:
            vectors = torch.as_tensor(np.stack(candidates), **like)
            costs = self.evaluate(rollout, vectors, generator)
            values = [c if math.isfinite(c) else 1e10 for c in costs.tolist()]
            state["evaluations"] += len(values)
            best = int(np.argmin(values))
            if values[best] < state["best"]:
                state["best"], state["best_vector"] = values[best], vectors[best].clone()
            info = StepInfo(
                result.steps, float(np.mean(values)), 0.0, math.nan, values[best], rollout.horizon
            )
            result.append(info)
            if on_step is not None:
                on_step(info)
            return values

        options = {
            "seed": seed,
            "verbose": -9,
            "CMA_stds": self.scales(rollout),
            "maxfevals": self.max_evaluations,
            "verb_log": 0,
            "verb_disp": 0,
        }
        if self.population is not None:
            options["popsize"] = self.population
        import cma  # here, not at the top: it loads scipy.stats and matplotlib (~1.2 s)

        cma.fmin2(
            None,
            start.cpu().numpy(),
            self.sigma,
            options=options,
            parallel_objective=objective,
            restarts=self.restarts,
            bipop=True,
            callback=lambda es: state["evaluations"] >= self.max_evaluations,
        )
        vector_to_parameters(state["best_vector"], policy.parameters())
        log.info(
            "trial %d: CMA-ES %d evaluations, best Ĵ %.3f",
            trial,
            state["evaluations"],
            state["best"],
        )
        return result
