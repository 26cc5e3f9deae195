"""Cart-pole physics, costs at known states and the success criterion."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import torch
from hydra import compose, initialize_config_dir
from hydra.utils import instantiate

from mcpilco.systems import CartPole
from mcpilco.trajectory import Trajectory

CONFIG_DIR = str(Path(__file__).resolve().parent.parent / "conf")


def test_energy_is_conserved_without_friction_and_input() -> None:
    system = CartPole(friction=0.0)
    state = np.array([0.2, 0.5, 2.0, -1.0])
    energy = system.energy(state)
    for _ in range(100):  # 5 s of free swinging
        state = system.step(state, np.zeros(1))
        assert system.energy(state) == pytest.approx(energy, abs=1e-7)


def test_friction_dissipates_and_input_does_work() -> None:
    system = CartPole()
    state = np.array([0.0, 1.0, 0.5, 0.0])
    assert system.energy(system.step(state, np.zeros(1))) < system.energy(state)
    pushed = system.step(np.zeros(4), np.array([10.0]))
    assert pushed[1] > 0  # pushing right accelerates the cart right
    assert pushed[3] < 0  # and swings the hanging pole back (θ measured anticlockwise)


def test_hanging_equilibrium_and_small_oscillation_period() -> None:
    system = CartPole(friction=0.0, cart_mass=1e6)  # cart effectively fixed
    np.testing.assert_allclose(system.derivatives(np.zeros(4), np.zeros(1)), 0.0)
    # Uniform rod about one end: ω² = 3 g / (2 L).
    omega = math.sqrt(3 * 9.81 / (2 * 0.5))
    state = np.array([0.0, 0.0, 1e-3, 0.0])
    for _ in range(int(round(2 * math.pi / omega / 0.05))):
        state = system.step(state, np.zeros(1))
    assert abs(state[2] - 1e-3) < 5e-5


def cost_module(name: str) -> torch.nn.Module:
    with initialize_config_dir(version_base="1.3", config_dir=CONFIG_DIR):
        cfg = compose("train", overrides=[f"cost={name}"])
    return instantiate(cfg.cost)


@pytest.mark.parametrize(
    "state,expected",
    [
        ([0.0, 0.0, math.pi, 0.0], 0.0),
        ([0.0, 3.0, -math.pi, -2.0], 0.0),  # both upright angles, velocities ignored
        ([1.0, 0.0, math.pi, 0.0], 1 - math.exp(-1.0)),
        ([0.0, 0.0, 0.0, 0.0], 1 - math.exp(-((math.pi / 3) ** 2))),
        ([-0.5, 0.0, math.pi / 2, 0.0], 1 - math.exp(-((math.pi / 6) ** 2) - 0.25)),
    ],
)
def test_training_cost_2_16_at_known_states(state: list[float], expected: float) -> None:
    value = cost_module("cartpole_swingup")(torch.tensor(state, dtype=torch.float64))
    assert float(value) == pytest.approx(expected, abs=1e-12)


def test_selective_cost_length_scales() -> None:
    value = cost_module("cartpole_swingup_selective")(torch.tensor([0.25, 0, math.pi, 0.0]))
    assert float(value) == pytest.approx(1 - math.exp(-1.0), rel=1e-6)


def test_evaluation_cost_2_17() -> None:
    system = CartPole()
    states = np.array([[0.0, 0, math.pi, 0], [0.0, 0, 0.0, 0], [0.3, 0, math.pi, 0]])
    # upright tip at the target; hanging tip 2L = 1 m below; cart 0.3 m off.
    expected = [0.0, 1 - math.exp(-0.5 * 16.0), 1 - math.exp(-0.5 * (0.3 / 0.25) ** 2)]
    np.testing.assert_allclose(system.evaluation_cost(states), expected, atol=1e-12)


def test_success_requires_the_whole_last_second() -> None:
    system = CartPole()
    states = np.zeros((61, 4))
    states[:, 2] = math.pi - 0.1  # 174°: inside the band
    trajectory = Trajectory(states, states, np.zeros((60, 1)), 0.05)
    assert system.evaluate(trajectory)["success"]
    states[40, 2] = math.pi - 0.2  # 168.5° at t = 2.0 s, the start of the last second
    assert not system.evaluate(Trajectory(states, states, np.zeros((60, 1)), 0.05))["success"]
    states[40, 2] = math.pi
    states[45, 0] = 0.15  # cart too far
    assert not system.evaluate(Trajectory(states, states, np.zeros((60, 1)), 0.05))["success"]


def test_sketch_draws_pole_tip_at_length_from_pivot() -> None:
    system = CartPole()
    states = np.array([[0.3, 0.0, math.pi, 0.0], [-0.2, 0.0, math.pi / 2, 0.0]])
    segments = system.sketch(states)  # [T+1, 2 segments, 2 points, xy]
    np.testing.assert_allclose(segments[0, 1, 1], [0.3, 0.5], atol=1e-12)  # upright tip
    np.testing.assert_allclose(segments[1, 1, 1], [0.3, 0.0], atol=1e-12)  # horizontal
    np.testing.assert_allclose(segments[:, 0, :, 1], 0.0)  # cart on the track
