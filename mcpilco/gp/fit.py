"""Hyper-parameter training by maximising the marginal likelihood."""

from __future__ import annotations

import logging
from dataclasses import dataclass

import torch

from mcpilco.errors import ConfigError
from mcpilco.gp.exact import ExactGP

log = logging.getLogger(__name__)


@dataclass
class MarginalLikelihoodFit:
    """Full-batch L-BFGS (strong-Wolfe line search) on −log p(y | X) / N.

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

        def closure() -> torch.Tensor:
            optimizer.zero_grad()
            loss = gp.negative_log_marginal_likelihood()
            loss.backward()
            return loss

        optimizer.step(closure)
        with torch.no_grad():
            final = float(gp.negative_log_marginal_likelihood())
        log.debug("GP %s fitted: -log p(y|X)/N = %.4f", gp.output_names, final)
        gp.precompute()
        return final
