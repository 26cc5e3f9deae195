"""Policies: the learned squashed-RBF network and exploration controllers."""

from mcpilco.policies.exploration import (
    ExplorationController,
    FilteredNoiseExploration,
    SumOfSinesExploration,
    TriangularWaveExploration,
    UniformRandomExploration,
)
from mcpilco.policies.rbf import SquashedRBFPolicy

__all__ = [
    "ExplorationController",
    "FilteredNoiseExploration",
    "SquashedRBFPolicy",
    "SumOfSinesExploration",
    "TriangularWaveExploration",
    "UniformRandomExploration",
]
