"""The MuJoCo cart-pole against the ODE cart-pole: one interface, the same physics."""

from __future__ import annotations

import numpy as np
import pytest
from hydra import compose, initialize_config_dir

from mcpilco.build import build
from mcpilco.errors import ConfigError
from mcpilco.systems import CartPole, CartPoleMujoco
from tests.test_config import CONFIG_DIR


def test_mujoco_and_ode_cartpole_agree_under_random_forces() -> None:
    ode, simulated = CartPole(), CartPoleMujoco()
    rng = np.random.default_rng(0)
    x = y = np.array([0.1, 0.5, 0.3, -1.0])
    for _ in range(40):  # 2 s, swinging through large angles
        action = rng.uniform(-10, 10, 1)
        x, y = ode.step(x, action), simulated.step(y, action)
        np.testing.assert_allclose(y, x, atol=1e-7)
    assert abs(x[2]) > 1.0  # the test covered the nonlinear regime


def test_config_builds_the_mujoco_backend_with_cartpole_settings() -> None:
    with initialize_config_dir(version_base="1.3", config_dir=str(CONFIG_DIR)):
        cfg = compose("train", overrides=["system=cartpole_mujoco", "kernel=sp"])
    system = build(cfg).components.system
    assert isinstance(system, CartPoleMujoco) and system.num_steps == 60
    rng = np.random.default_rng(0)
    trajectory = system.rollout(lambda _y, _t: np.array([3.0]), np.zeros(4), 10, rng)
    assert trajectory.states[-1, 0] > 0.05  # pushed to the right
    with pytest.raises(ConfigError, match="system.timestep"):
        CartPoleMujoco(timestep=0.003)
