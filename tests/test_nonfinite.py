"""NaN and inf anywhere in a run stop it at once, naming where; no simulation step blocks."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import torch
from hydra import compose, initialize_config_dir

from mcpilco.build import build
from mcpilco.errors import NonFiniteError, SimulationError
from mcpilco.models.base import ModelStructure
from mcpilco.run_storage import RunDirectory
from mcpilco.systems import CartPole, CartPoleMujoco, OdeSystem
from mcpilco.trial_loop import TrialLoop

ROOT = Path(__file__).resolve().parent.parent
TINY = [
    "num_trials=3",
    "threads=1",
    "compile=false",
    "optimizer.num_particles=8",
    "optimizer.max_steps=4",
    "optimizer.max_steps_first_trial=4",
    "policy.num_basis=10",
    "system.trial_duration=0.5",
]

FAULTY = '''
import numpy as np
from mcpilco.systems import CartPole


class FaultyCartPole(CartPole):
    """A cart-pole whose sensor returns one NaN: in rollout ``nan_rollout`` (1 = the
    exploration), at step ``nan_step``, in reading component ``nan_component``."""

    def __init__(self, nan_rollout=3, nan_step=5, nan_component=2, **kwargs):
        super().__init__(**kwargs)
        self.nan = (nan_rollout, nan_step, nan_component)
        self.rollouts = 0
        self.steps = 0

    def rollout(self, controller, x0, num_steps, rng):
        self.rollouts, self.steps = self.rollouts + 1, 0
        return super().rollout(controller, x0, num_steps, rng)

    def measure(self, state, rng):
        reading = super().measure(state, rng)
        if (self.rollouts, self.steps) == self.nan[:2]:
            reading[self.nan[2]] = np.nan
        self.steps += 1
        return reading
'''


@pytest.fixture
def no_hang() -> Iterator[None]:
    """Fail (instead of hanging the suite) if the test body runs past 60 s."""

    def expire(_signum: int, _frame: object) -> None:
        raise TimeoutError("blocked for 60 s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.alarm(60)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def test_nan_reading_stops_the_run_with_one_line_and_keeps_finished_trials(
    tmp_path: Path,
) -> None:
    (tmp_path / "faulty.py").write_text(textwrap.dedent(FAULTY))
    run_dir = tmp_path / "run"
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "runners.train",
            *TINY,
            "system._target_=faulty.FaultyCartPole",
            "+system.nan_rollout=3",  # trial 2's rollout
            "+system.nan_step=5",
            f"hydra.run.dir={run_dir}",
        ],
        cwd=Path.cwd(),
        env={**os.environ, "PYTHONPATH": f"{tmp_path}{os.pathsep}{ROOT}"},
        capture_output=True,
        text=True,
        timeout=600,  # a hang guard (the defect was a hang), not a time limit
    )
    assert result.returncode == 1, result.stderr[-2000:]
    errors = [line for line in (result.stdout + result.stderr).splitlines() if "ERROR" in line]
    assert len(errors) == 1, errors
    assert "trial 2, step 5: the reading component 2 (θ [rad]) is nan" in errors[0]
    assert "Traceback" not in result.stderr
    assert (run_dir / "failed.txt").is_file()
    assert "NonFiniteError" in (run_dir / "failed.txt").read_text()
    assert pd.read_csv(run_dir / "summary.csv")["trial"].tolist() == [0, 1]
    assert (run_dir / "checkpoints" / "trial_01" / "policy.pt").is_file()


def test_nan_action_never_reaches_the_integrator(no_hang: None) -> None:
    system = CartPole(trial_duration=0.5)
    rng = np.random.default_rng(0)
    for bad in (np.nan, np.inf, -np.inf):

        def controller(_reading: np.ndarray, step: int, bad: float = bad) -> np.ndarray:
            return np.array([bad if step == 3 else 0.5])

        with pytest.raises(NonFiniteError, match=rf"^step 3: the action component 0 is {bad!r}"):
            system.rollout(controller, np.array([0.1, 0.2, 0.3, 0.4]), 10, rng)


def test_an_ode_step_never_blocks(no_hang: None) -> None:
    """scipy's DOP853 loops forever on NaN derivatives (the hang of issue 27); ours raises
    on them, on a NaN input, and past a bound on work."""
    system = CartPole()
    state = np.array([0.1, 0.2, 0.3, 0.4])
    with pytest.raises(NonFiniteError, match="the action to integrate component 0 is nan"):
        system.step(state, np.array([np.nan]))

    class NanDynamics(OdeSystem):
        position_indices, velocity_indices = (0,), (1,)

        def derivatives(self, state: np.ndarray, action: np.ndarray) -> np.ndarray:
            return np.array([state[1], np.nan if state[0] > 0.1 else -state[0]])

    plant = NanDynamics(
        dt=1.0, trial_duration=1.0, u_max=1.0, measurement_noise_std=0.01,
        initial_mean=[0, 0], initial_std=0.0,
    )  # fmt: skip
    with pytest.raises(NonFiniteError, match="dynamics of NanDynamics returned"):
        plant.step(np.array([0.0, 1.0]), np.array([0.0]))

    class Stiff(NanDynamics):
        max_evaluations = 500

        def derivatives(self, state: np.ndarray, action: np.ndarray) -> np.ndarray:
            return -1e9 * state  # explicit DOP853 needs ~1e9 evaluations for 1 s

    stiff = Stiff(
        dt=1.0, trial_duration=1.0, u_max=1.0, measurement_noise_std=0.01,
        initial_mean=[0, 0], initial_std=0.0,
    )  # fmt: skip
    with pytest.raises(SimulationError, match="more than 500 evaluations"):
        stiff.step(np.array([1.0, 1.0]), np.array([0.0]))


def test_mujoco_instability_is_an_error_not_a_silent_reset(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)  # MuJoCo writes its warning to MUJOCO_LOG.TXT here
    simulation = CartPoleMujoco(trial_duration=0.5).simulation
    with pytest.raises(SimulationError, match="BADQVEL"):
        simulation.step(np.zeros(2), np.array([1e30, 0.0]), np.array([0.0]))
    qpos, qvel = simulation.step(np.zeros(2), np.zeros(2), np.array([1.0]))  # still usable
    assert np.all(np.isfinite(qpos)) and qvel[0] > 0


def tiny_experiment(*overrides: str):  # type: ignore[no-untyped-def]
    with initialize_config_dir(version_base="1.3", config_dir=str(ROOT / "conf")):
        return build(compose("train", overrides=[*TINY, *overrides]))


def test_nan_in_the_exploration_rollout_names_trial_zero(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Before: a NaN in the exploration surfaced much later as a non-positive-definite
    kernel matrix that never mentioned NaN."""
    experiment = tiny_experiment()
    original = CartPole.measure
    calls = {"count": 0}

    def measure(self, state, rng):  # type: ignore[no-untyped-def]
        calls["count"] += 1
        reading = original(self, state, rng)
        if calls["count"] == 8:  # step 7 of the exploration
            reading[1] = np.inf
        return reading

    monkeypatch.setattr(CartPole, "measure", measure)
    loop = TrialLoop(experiment.components, RunDirectory(tmp_path), experiment.streams, 1)
    with pytest.raises(NonFiniteError, match=r"^trial 0, step 7: the reading component 1 \(ṗ"):
        loop.run()
    assert not (tmp_path / "summary.csv").exists()


def test_nan_from_the_offline_estimator_names_the_data(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    experiment = tiny_experiment()
    estimator = experiment.components.estimator
    original = estimator.offline

    def offline(measurements, dt, actions=None):  # type: ignore[no-untyped-def]
        states = original(measurements, dt, actions).copy()
        states[4, 3] = np.nan
        return states

    monkeypatch.setattr(estimator, "offline", offline)
    loop = TrialLoop(experiment.components, RunDirectory(tmp_path), experiment.streams, 1)
    with pytest.raises(
        NonFiniteError,
        match=r"^trial 1: step 4: the offline state estimate of trial 0's rollout component 3",
    ):
        loop.run()
    assert pd.read_csv(tmp_path / "summary.csv")["trial"].tolist() == [0]


def test_a_model_that_predicts_nan_stops_the_run_naming_step_and_component(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    experiment = tiny_experiment()
    original = ModelStructure.step

    def step(self, particles, actions, noise, encoded=None):  # type: ignore[no-untyped-def]
        following = original(self, particles, actions, noise, encoded).clone()
        following[:, 2] = torch.nan
        return following

    monkeypatch.setattr(ModelStructure, "step", step)
    loop = TrialLoop(experiment.components, RunDirectory(tmp_path), experiment.streams, 2)
    with pytest.raises(
        NonFiniteError,
        match=r"^trial 1: policy optimisation made no finite step .* at step 1, component 2 \(θ",
    ):
        loop.run()
    assert pd.read_csv(tmp_path / "summary.csv")["trial"].tolist() == [0]
