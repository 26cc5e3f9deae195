"""Policy optimisation on particles (Algorithm 1, step 2)."""

from mcpilco.optim.base import PolicySearch
from mcpilco.optim.blackdrops import BlackDropsSearch
from mcpilco.optim.monitor import MonitoringSchedule, ScheduleEvent
from mcpilco.optim.pilco import PilcoSearch
from mcpilco.optim.policy_optimizer import OptimizationResult, PolicyOptimizer, StepInfo
from mcpilco.optim.rollout import ParticleRollout, RolloutResult

__all__ = [
    "BlackDropsSearch",
    "PilcoSearch",
    "PolicySearch",
    "MonitoringSchedule",
    "OptimizationResult",
    "ParticleRollout",
    "PolicyOptimizer",
    "RolloutResult",
    "ScheduleEvent",
    "StepInfo",
]
