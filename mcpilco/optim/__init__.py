"""Policy optimisation on particles (Algorithm 1, step 2)."""

from mcpilco.optim.monitor import MonitoringSchedule, ScheduleEvent
from mcpilco.optim.policy_optimizer import OptimizationResult, PolicyOptimizer, StepInfo
from mcpilco.optim.rollout import ParticleRollout, RolloutResult

__all__ = [
    "MonitoringSchedule",
    "OptimizationResult",
    "ParticleRollout",
    "PolicyOptimizer",
    "RolloutResult",
    "ScheduleEvent",
    "StepInfo",
]
