"""system=gymnasium: any Gymnasium environment as a system (issue 58). References: the
environments' own reward formulas, known angle trajectories, environments written here
with known dynamics."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")
from gymnasium import spaces  # noqa: E402

from mcpilco.errors import ConfigError, SimulationError  # noqa: E402
from mcpilco.systems.gymnasium_env import GymnasiumSystem  # noqa: E402
from mcpilco.systems.observation_map import ObservationMap  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
PENDULUM_MAP = {"positions": [{"cos": 0, "sin": 1}], "velocities": [{"index": 2}]}


class SpinningDict(gymnasium.Env):
    """θ_{t+1} = θ_t + 0.1 + u_t (rad) with a Dict observation {"angle": [cos θ, sin θ],
    "rate": [[θ̇]]}; reward −u²; terminates after ``end_after`` steps; starts at θ0 =
    seed / 1000 rad, θ̇0 = (seed mod 1000) / 1000 rad/s."""

    metadata: dict[str, Any] = {"render_modes": []}

    def __init__(self, end_after: int = 1000) -> None:
        self.observation_space = spaces.Dict(
            {
                "angle": spaces.Box(-1, 1, (2,), dtype=np.float64),
                "rate": spaces.Box(-np.inf, np.inf, (1, 1), dtype=np.float64),
            }
        )
        self.action_space = spaces.Box(-0.5, 0.5, (1,), dtype=np.float64)
        self.dt = 0.1
        self.end_after = end_after

    def _observation(self) -> dict[str, np.ndarray]:
        return {
            "angle": np.array([np.cos(self.theta), np.sin(self.theta)]),
            "rate": np.array([[self.rate]]),
        }

    def reset(self, *, seed: int | None = None, options: Any = None) -> tuple[Any, dict]:
        super().reset(seed=seed)
        seed = seed or 0
        self.theta, self.rate, self.steps = seed / 1000.0, (seed % 1000) / 1000.0, 0
        return self._observation(), {}

    def step(self, action: np.ndarray) -> tuple[Any, float, bool, bool, dict]:
        change = 0.1 + float(action[0])
        self.theta, self.rate, self.steps = self.theta + change, change / self.dt, self.steps + 1
        return (
            self._observation(),
            -(float(action[0]) ** 2),
            self.steps >= self.end_after,
            False,
            {},
        )


gymnasium.register("MCPilcoSpinningDict-v0", entry_point=SpinningDict, max_episode_steps=50)
DICT_MAP = {
    "positions": [{"cos": 0, "sin": 1, "key": "angle"}],
    "velocities": [{"index": 0, "key": "rate"}],
}
DECLARED = {"distribution": "uniform", "mean": [0.0, 0.0], "std": [1.0, 0.0]}


def test_angles_are_recovered_and_unwrapped_along_a_known_trajectory() -> None:
    space = spaces.Box(-np.inf, np.inf, (3,))
    reader = ObservationMap(PENDULUM_MAP["positions"], PENDULUM_MAP["velocities"], space)
    times = np.arange(0, 20, 0.05)
    for theta in (3.0 + 1.3 * times, -0.4 - 2.9 * times + 0.5 * np.sin(times)):  # turns both ways
        rate = np.gradient(theta, times)
        states, previous = [], None
        for angle, velocity in zip(theta, rate, strict=True):
            previous = reader.state(np.array([np.cos(angle), np.sin(angle), velocity]), previous)
            states.append(previous)
        states = np.array(states)
        # the first angle is read in (-π, π]; the rest follow it continuously
        offset = theta[0] - states[0, 0]
        assert abs(offset / (2 * np.pi) - round(offset / (2 * np.pi))) < 1e-12
        np.testing.assert_allclose(states[:, 0] + offset, theta, atol=1e-9)
        np.testing.assert_allclose(states[:, 1], rate, atol=1e-12)
        assert np.ptp(states[:, 0]) > 4 * np.pi  # several turns, no wrap back


def test_a_dict_observation_and_early_termination() -> None:
    system = GymnasiumSystem("MCPilcoSpinningDict-v0", DICT_MAP, DECLARED, {"end_after": 7})
    assert (system.dt, system.u_max, system.num_steps, system.angle_indices) == (0.1, 0.5, 50, (0,))
    rng = np.random.default_rng(0)
    x0 = system.sample_initial_state(rng)
    trajectory = system.rollout(lambda y, t: np.array([0.2]), x0, system.num_steps, rng)
    assert trajectory.num_steps == 7  # the episode ended: the data up to it
    expected = x0[0] + 0.3 * np.arange(8)  # 0.1 + u per step, past π without a wrap
    np.testing.assert_allclose(trajectory.states[:, 0], expected, atol=1e-12)
    np.testing.assert_allclose(trajectory.states[1:, 1], 3.0, atol=1e-12)
    np.testing.assert_allclose(trajectory.rewards, -0.04)
    metrics = system.evaluate(trajectory)
    assert metrics == {"env_return": pytest.approx(-0.28), "env_steps": 7, "terminated": True}
    with pytest.raises(SimulationError, match="starts where its reset puts it"):
        system.rollout(lambda y, t: np.array([0.0]), x0 + 1.0, 3, rng)


def test_the_search_horizon_is_its_own_key() -> None:
    from mcpilco.optim.rollout import ParticleRollout

    system = GymnasiumSystem(
        "MCPilcoSpinningDict-v0", DICT_MAP, DECLARED, trial_duration=2.0, search_duration=3.5
    )
    assert (system.num_steps, system.search_steps, system.episode_steps) == (20, 35, 50)

    class Policy:
        def parameters(self) -> Any:
            import torch

            yield torch.zeros(1, dtype=torch.float64)

    rollout = ParticleRollout.for_system(system, None, Policy(), None, None, False)  # type: ignore[arg-type]
    assert rollout.horizon == 35


def test_p_x0_estimated_from_seeded_resets() -> None:
    # seeds drawn in [0, 2^31): θ0 read in (-π, π] is uniform there, θ̇0 uniform on [0, 1)
    initial = {"distribution": "uniform", "estimate_from_resets": 400, "seed": 3}
    system = GymnasiumSystem("MCPilcoSpinningDict-v0", DICT_MAP, initial)
    np.testing.assert_allclose(system.initial_mean, [0.0, 0.5], atol=0.03)
    np.testing.assert_allclose(system.initial_std, [np.pi, 0.5], rtol=0.02)
    normal = GymnasiumSystem(
        "MCPilcoSpinningDict-v0", DICT_MAP, {**initial, "distribution": "normal"}
    )  # the std of U(a, b) is (b - a) / √12
    np.testing.assert_allclose(normal.initial_std, [2 * np.pi, 1.0] / np.sqrt(12), rtol=0.08)
    assert system.describe()["initial"]["source"] == "estimated from 400 resets (seed 3)"
    again = GymnasiumSystem("MCPilcoSpinningDict-v0", DICT_MAP, initial)
    np.testing.assert_array_equal(again.initial_mean, system.initial_mean)


def pendulum_reward(theta: np.ndarray, rate: np.ndarray, torque: np.ndarray) -> np.ndarray:
    """Gymnasium's Pendulum-v1 reward, from its documentation: −(θ_n² + 0.1 θ̇² + 0.001 u²),
    θ_n the angle normalised to [−π, π), the state before the step."""
    normalised = (theta + np.pi) % (2 * np.pi) - np.pi
    return -(normalised**2 + 0.1 * rate**2 + 0.001 * torque**2)


def run_module(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", *args], cwd=ROOT, capture_output=True, text=True, timeout=600
    )


def test_pendulum_end_to_end_env_return_is_the_rewards_summed(tmp_path: Path) -> None:
    import pandas as pd

    run = tmp_path / "run"
    result = run_module(
        "runners.train", "+experiment=gym_pendulum", "num_trials=1", "threads=1",
        "compile=false", "optimizer.num_particles=8", "optimizer.max_steps=3",
        "optimizer.max_steps_first_trial=3", "policy.num_basis=10", "system.trial_duration=2.0",
        f"hydra.run.dir={run}",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr[-3000:]
    summary = pd.read_csv(run / "summary.csv")
    for trial in (0, 1):
        with np.load(run / "trajectories" / f"trial_{trial:02d}.npz") as arrays:
            states, actions = arrays["states"], arrays["actions"]
        expected = pendulum_reward(states[:-1, 0], states[:-1, 1], actions[:, 0]).sum()
        # the states are read off float32 observations; the environment rewards its float64
        # state: they agree to float32's precision
        assert summary.env_return[trial] == pytest.approx(expected, rel=1e-6)
        assert summary.env_steps[trial] == 40
    assert (run / "rollouts.mcap").stat().st_size > 0 and (run / "system.json").is_file()
    from mcpilco.tracking.reader import read_run_log

    logged = read_run_log(run / "rollouts.mcap").trials
    assert logged["env_return"].tolist() == pytest.approx(summary.env_return.tolist())
    assert logged["env_steps"].tolist() == [40.0, 40.0]
    evaluated = run_module("analysis.evaluate", str(run), "--trial", "1", "--episodes", "2")
    assert evaluated.returncode == 0, evaluated.stderr[-2000:]
    assert "env_return: mean" in evaluated.stdout and "env_steps: mean 200" in evaluated.stdout


@pytest.mark.parametrize(
    "overrides,message",
    [
        (["system=gymnasium", "system.env_id=NoSuchEnvironment-v0"],
         "system.env_id='NoSuchEnvironment-v0' is not a"),
        (["system=gymnasium", "system.env_id=Pendulum-v1"],
         "system.state_map is needed for Pendulum-v1"),
        (
            ["system=gymnasium", "system.env_id=Pendulum-v1",
             "+system.state_map.positions=[{index: 5}]",
             "+system.state_map.velocities=[{index: 2}]"],
            "system.state_map.positions[0] reads component 5 of an observation of 3",
        ),
        (["system=gym_pendulum", "system.u_max=9"], "system.u_max=9"),
        (["system=gym_pendulum", "system.trial_duration=11"], "longer than Pendulum-v1's episode"),
        (["system=gym_pendulum", "system.search_duration=0.07"], "system.search_duration=0.07"),
        (["system=gym_pendulum", "system.initial.std=[1, 2, 3]"], "system.initial.std"),
        (["system=gym_pendulum", "system.dt=0.1"], "system.dt=0.1 differs"),
    ],
)  # fmt: skip
def test_bad_environments_are_refused_in_one_line(overrides: list[str], message: str) -> None:
    from hydra import compose, initialize_config_dir

    from mcpilco.build import build

    with initialize_config_dir(version_base="1.3", config_dir=str(ROOT / "conf")):
        cfg = compose("train", overrides=overrides)
    with pytest.raises(ConfigError) as error:
        build(cfg)
    assert message in str(error.value) and "\n" not in str(error.value)


@pytest.mark.parametrize(
    "state_map,message",
    [
        ({"positions": [{"cos": 0}], "velocities": [{"index": 0}]}, "both cos and sin"),
        ({"positions": [{"index": 0}], "velocities": []}, "one velocity per position"),
        ({"positions": [{"cos": 0, "sin": 1}], "velocities": [{"index": 0}]}, "needs key"),
        (
            {"positions": [{"index": 0, "key": "spin"}],
             "velocities": [{"index": 0, "key": "rate"}]},
            "key='spin' is not an entry",
        ),
        ({"source": "simulator"}, "not a MuJoCo environment"),
    ],
)  # fmt: skip
def test_a_state_map_that_does_not_fit_the_space(state_map: dict, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        GymnasiumSystem("MCPilcoSpinningDict-v0", state_map, DECLARED)


def test_a_missing_extra_says_how_to_install_it(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "gymnasium", None)  # import gymnasium now fails
    with pytest.raises(
        ConfigError, match=r"needs the gymnasium package.*pip install -e '\.\[gym\]'"
    ):
        GymnasiumSystem("Pendulum-v1", PENDULUM_MAP, DECLARED)


def test_a_mujoco_environment_read_off_its_simulator() -> None:
    pytest.importorskip("mujoco")
    system = GymnasiumSystem(
        "InvertedPendulum-v5", None, {"distribution": "uniform", "mean": 0.0, "std": 0.01}
    )
    assert (system.state_dim, system.angle_indices, system.dt, system.u_max) == (4, (1,), 0.04, 3.0)
    rng = np.random.default_rng(1)
    x0 = system.sample_initial_state(rng)
    trajectory = system.rollout(lambda y, t: np.array([3.0]), x0, 100, rng)
    # the observation of InvertedPendulum-v5 is [qpos, qvel]: the same numbers
    observation = system.env.unwrapped._get_obs()
    np.testing.assert_allclose(trajectory.states[-1], observation, atol=1e-12)
    assert trajectory.num_steps < 100 and abs(trajectory.states[-1, 1]) > 0.2  # it fell
    # v5's reward: 1 per step that does not end the episode
    assert system.evaluate(trajectory)["env_return"] == trajectory.num_steps - 1


def test_pendulum_torch_equations_match_the_environment() -> None:
    import torch

    system = GymnasiumSystem("Pendulum-v1", PENDULUM_MAP, DECLARED | {"std": [np.pi, 1.0]})
    rng = np.random.default_rng(4)
    x0 = system.sample_initial_state(rng)
    trajectory = system.rollout(lambda y, t: rng.uniform(-2, 2, 1), x0, 200, rng)
    states = torch.as_tensor(trajectory.states)
    predicted = system.torch_step(states[:-1], torch.as_tensor(trajectory.actions))
    # the environment's own steps, read back through float32 observations
    np.testing.assert_allclose(predicted.numpy(), trajectory.states[1:], atol=2e-5)
    assert np.ptp(trajectory.states[:, 0]) > 1.0  # it moved
    with pytest.raises(NotImplementedError, match="no torch equations"):
        GymnasiumSystem("MCPilcoSpinningDict-v0", DICT_MAP, DECLARED).torch_step(states, states)
