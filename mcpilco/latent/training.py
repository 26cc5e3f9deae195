"""Training a CGPDM: L-BFGS on eq. 6.11, in the outer/inner loop of the authors' library.

The thesis trains with L-BFGS (§6.3); the authors' public code runs ``steps`` calls of
``torch.optim.LBFGS.step`` with a small learning rate (0.01), at most 20 iterations per call,
a memory of 7 and a strong-Wolfe line search. We keep that schedule as the default, since it
is part of how the thesis's models came about: run to convergence, the marginal likelihood of
a GPDM, whose latent states are free, keeps improving by overfitting them (on our cloth the
latent rollouts of models trained 300 full-step iterations diverged far more often than
those trained 100). The loss after every outer step is returned (the training trace).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import torch

from mcpilco.errors import ConfigError, NotPositiveDefiniteError
from mcpilco.latent.cgpdm import CGPDM

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class CGPDMTraining:
    """L-BFGS schedule.

    Attributes:
        steps: outer steps (calls of ``LBFGS.step``).
        iterations_per_step: L-BFGS iterations per outer step (``max_iter``).
        learning_rate: L-BFGS ``lr`` (scales the first trial step of each line search).
        history_size: L-BFGS memory.
    """

    steps: int = 26
    iterations_per_step: int = 20
    learning_rate: float = 0.01
    history_size: int = 7

    def __post_init__(self) -> None:
        for name in ("steps", "iterations_per_step", "history_size"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 1:
                raise ConfigError(f"train.{name}={value!r} must be a positive integer")
        if not self.learning_rate > 0:
            raise ConfigError(f"train.learning_rate={self.learning_rate!r} must be positive")

    def __call__(self, model: CGPDM) -> list[float]:
        """Train ``model`` (data set) in place; the loss (eq. 6.11 / N) after each step.

        A line-search trial point whose kernel matrix is not positive definite even with
        jitter ends training at the best parameters evaluated (a warning says so)."""
        parameters = [p for p in model.parameters() if p.requires_grad]
        optimizer = torch.optim.LBFGS(
            parameters, lr=self.learning_rate, max_iter=self.iterations_per_step,
            history_size=self.history_size, line_search_fn="strong_wolfe",
        )  # fmt: skip
        best = (math.inf, [p.detach().clone() for p in parameters])

        def closure() -> torch.Tensor:
            nonlocal best
            optimizer.zero_grad()
            loss = model.negative_log_marginal_likelihood()
            loss.backward()
            value = float(loss.detach())
            if value < best[0]:
                best = (value, [p.detach().clone() for p in parameters])
            return loss

        trace: list[float] = []
        try:
            for _ in range(self.steps):
                optimizer.step(closure)
                trace.append(best[0])
        except NotPositiveDefiniteError as error:
            if math.isinf(best[0]):
                raise
            log.warning("CGPDM training stopped early (%s); keeping the best point", error)
        with torch.no_grad():
            for parameter, value in zip(parameters, best[1], strict=True):
                parameter.copy_(value)
        model.precompute()
        return trace
