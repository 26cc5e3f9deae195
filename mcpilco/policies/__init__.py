"""Policies: the learned squashed-RBF network and exploration controllers."""

from mcpilco.policies.exploration import UniformRandomExploration
from mcpilco.policies.rbf import SquashedRBFPolicy

__all__ = ["SquashedRBFPolicy", "UniformRandomExploration"]
