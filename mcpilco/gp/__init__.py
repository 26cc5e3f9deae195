"""Exact GP regression for several independent outputs, batched over the outputs."""

from mcpilco.gp.exact import ExactGP
from mcpilco.gp.fit import MarginalLikelihoodFit
from mcpilco.gp.linalg import cholesky_with_jitter
from mcpilco.gp.reduction import reduce_dataset

__all__ = ["ExactGP", "MarginalLikelihoodFit", "cholesky_with_jitter", "reduce_dataset"]
