"""Hyper-parameter training by maximising the marginal likelihood."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import torch

from mcpilco.errors import ConfigError, NotPositiveDefiniteError
from mcpilco.extension import ExtensionPoint
from mcpilco.gp.exact import ExactGP

log = logging.getLogger(__name__)


@dataclass
class MarginalLikelihoodFit(ExtensionPoint):
    """Full-batch L-BFGS (strong-Wolfe line search) on −log p(y | X) / N.

    If a trial point of the line search makes a kernel matrix non-positive-definite even
    with jitter, the fit stops there with the best hyper-parameters evaluated so far (a
    warning says so); only initial hyper-parameters that fail raise the error.

    All G outputs are trained at once: their hyper-parameters are disjoint, so the summed
    objective has a block-diagonal Hessian and each block converges as if alone.

    Args:
        max_iterations: L-BFGS iterations (each may evaluate the objective several times).
        tolerance: stop when the objective changes less than this between iterations.
        history_size: L-BFGS memory.
    """

    max_iterations: int = 200
    tolerance: float = 1e-9
    history_size: int = 20

    def __post_init__(self) -> None:
        if self.max_iterations < 1:
            raise ConfigError(f"gp_fit.max_iterations must be >= 1, got {self.max_iterations}")

    def __call__(self, gp: ExactGP) -> float:
        """Train ``gp`` in place; return the final −log p(y | X) / N."""
        parameters = [p for p in gp.parameters() if p.requires_grad]
        optimizer = torch.optim.LBFGS(
            parameters,
            lr=1.0,
            max_iter=self.max_iterations,
            tolerance_grad=1e-9,
            tolerance_change=self.tolerance,
            history_size=self.history_size,
            line_search_fn="strong_wolfe",
        )

        best_loss, best_values = math.inf, list[torch.Tensor]()

        def closure() -> torch.Tensor:
            nonlocal best_loss, best_values
            optimizer.zero_grad()
            loss = gp.negative_log_marginal_likelihood()
            loss.backward()
            value = float(loss.detach())
            if value < best_loss:
                best_loss, best_values = value, [p.detach().clone() for p in parameters]
            return loss

        try:
            optimizer.step(closure)
        except NotPositiveDefiniteError as error:
            if not best_values:  # not even the initial hyper-parameters work
                raise
            # A line-search trial point left the positive-definite region (e.g. an SE×P(2)
            # product grown far larger than the noise): keep the best point evaluated.
            log.warning(
                "GP %s fit stopped early (%s); keeping the best hyper-parameters evaluated, "
                "-log p(y|X)/N = %.4f",
                gp.output_names,
                error,
                best_loss,
            )
            with torch.no_grad():
                for parameter, value in zip(parameters, best_values, strict=True):
                    parameter.copy_(value)
        with torch.no_grad():
            final = float(gp.negative_log_marginal_likelihood())
        log.debug("GP %s fitted: -log p(y|X)/N = %.4f", gp.output_names, final)
        gp.precompute()
        return final
