"""An example plug-in: a damped pendulum learned by MC-PILCO without editing mcpilco.

    PYTHONPATH=$PWD/examples/pendulum_plugin python -m runners.train \\
        hydra.searchpath=[file://$PWD/examples/pendulum_plugin/conf] \\
        system=pendulum cost=pendulum_swingup

(see docs/extending.md). The module must be importable from ``PYTHONPATH`` or installed:
mcpilco never imports a ``_target_`` found only through the working directory.
"""

from __future__ import annotations

import numpy as np

from mcpilco.systems import OdeSystem


class Pendulum(OdeSystem):
    """A damped pendulum driven by a torque: state [θ (rad, 0 hanging), θ̇ (rad/s)], action
    [u] (N m per unit inertia, |u| ≤ ``u_max``); ``length`` (m) and ``damping`` (1/s)."""

    position_indices = (0,)
    velocity_indices = (1,)
    angle_indices = (0,)
    action_dim = 1

    def __init__(self, length: float = 1.0, damping: float = 0.1, **kwargs: object) -> None:
        super().__init__(**kwargs)
        self.length, self.damping = length, damping

    def derivatives(self, state: np.ndarray, action: np.ndarray) -> np.ndarray:
        """ẋ = [θ̇, −g/l sin θ − d θ̇ + u] for one state ``[2]`` and action ``[1]``."""
        theta, omega = state
        acceleration = -9.81 / self.length * np.sin(theta) - self.damping * omega + action[0]
        return np.array([omega, acceleration])
