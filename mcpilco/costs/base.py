"""The cost interface: what the policy search minimises, state by state."""

from __future__ import annotations

from abc import ABC, abstractmethod

import torch
from torch import nn

from mcpilco.extension import ExtensionPoint


class Cost(ExtensionPoint, nn.Module, ABC):
    """c(x): a differentiable cost of each state. Subclass this for your own cost (and name
    it with ``cost._target_=my_pkg.MyCost``); a run directory's config may name only
    subclasses of mcpilco's extension points (see :mod:`mcpilco.safe_config`)."""

    @abstractmethod
    def forward(self, states: torch.Tensor) -> torch.Tensor:
        """Cost ``[...]`` of states ``[..., d_x]`` (units of the task's cost, ≥ 0)."""
