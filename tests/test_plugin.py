"""A user's own system and cost, from their own module and YAML, without editing mcpilco."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parent.parent

PENDULUM = '''
import numpy as np
from mcpilco.systems import OdeSystem


class Pendulum(OdeSystem):
    """Damped pendulum, state [theta, theta_dot], torque input."""

    position_indices = (0,)
    velocity_indices = (1,)
    angle_indices = (0,)
    action_dim = 1

    def __init__(self, length=1.0, damping=0.1, **kwargs):
        super().__init__(**kwargs)
        self.length, self.damping = length, damping

    def derivatives(self, state, action):
        theta, omega = state
        accel = -9.81 / self.length * np.sin(theta) - self.damping * omega + action[0]
        return np.array([omega, accel])
'''

SYSTEM_YAML = """
_target_: my_plants.Pendulum
dt: 0.05
trial_duration: 0.5
u_max: 2.0
measurement_noise_std: 0.01
initial_mean: [0.0, 0.0]
initial_std: 0.01
length: 0.8
"""

COST_YAML = """
_target_: mcpilco.costs.SaturatingDistance
terms:
  - {index: 0, target: 3.141592653589793, length_scale: 1.0, absolute: true}
"""


@pytest.mark.slow  # CI time (make test-slow runs it)
def test_user_system_and_cost_plug_in(tmp_path: Path) -> None:
    (tmp_path / "my_plants.py").write_text(textwrap.dedent(PENDULUM))
    (tmp_path / "conf" / "system").mkdir(parents=True)
    (tmp_path / "conf" / "cost").mkdir()
    (tmp_path / "conf" / "system" / "pendulum.yaml").write_text(SYSTEM_YAML)
    (tmp_path / "conf" / "cost" / "upright.yaml").write_text(COST_YAML)
    env = {**os.environ, "PYTHONPATH": f"{tmp_path}{os.pathsep}{ROOT}"}
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "runners.train",
            f"hydra.searchpath=[file://{tmp_path / 'conf'}]",
            "system=pendulum",
            "cost=upright",
            "num_trials=1",
            "threads=1",
            "optimizer.num_particles=8",
            "optimizer.max_steps_first_trial=3",
            "policy.num_basis=5",
            f"hydra.run.dir={tmp_path / 'run'}",
        ],
        cwd=Path.cwd(),
        env=env,
        capture_output=True,
        text=True,
        timeout=600,  # a hang guard, not a time limit (a loaded machine is slow)
    )
    assert result.returncode == 0, result.stderr[-2000:]
    summary = pd.read_csv(tmp_path / "run" / "summary.csv")
    assert summary["trial"].tolist() == [0, 1]
    assert summary.loc[1, "gp_samples"] == 10  # one exploration rollout of 10 steps
    # The analysis commands work on a system without evaluation cost or success criterion.
    summary_cli = subprocess.run(
        [sys.executable, "-m", "analysis.summary", str(tmp_path / "run")],
        cwd=Path.cwd(), env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert summary_cli.returncode == 0, summary_cli.stderr[-2000:]
    assert "| SE | 0 | — | — | — |" in summary_cli.stdout
    evaluation = subprocess.run(
        [sys.executable, "-m", "analysis.evaluate", str(tmp_path / "run"), "--runs", "3"],
        cwd=Path.cwd(), env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert evaluation.returncode == 0, evaluation.stderr[-2000:]
    assert "no success count" in evaluation.stdout and "0/3" not in evaluation.stdout
    result = json.loads((tmp_path / "run" / "evaluation" / "trial_01.json").read_text())
    assert result["success_criterion"] is False and result["system_successes"] is None
    assert len(result["system_runs"]) == 3
    # Replay needs the log alone: without the plug-in importable it warns and replays.
    for environment, warned in ((env, False), ({**os.environ, "PYTHONPATH": str(ROOT)}, True)):
        replay = subprocess.run(
            [sys.executable, "-m", "runners.replay", str(tmp_path / "run")],
            cwd=Path.cwd(), env=environment, capture_output=True, text=True, timeout=600,
        )  # fmt: skip
        assert replay.returncode == 0, replay.stderr[-2000:]
        assert ("my_plants.Pendulum" in replay.stderr) is warned
        assert "Traceback" not in replay.stderr
        assert (tmp_path / "run" / "replay.rrd").stat().st_size > 1000
    report = subprocess.run(
        [sys.executable, "-m", "analysis.report", str(tmp_path / "run")],
        cwd=Path.cwd(), env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert report.returncode == 0, report.stderr[-2000:]
    index = (tmp_path / "run" / "report" / "index.md").read_text()
    assert "no success rates: the system reports no success criterion" in index
    assert (tmp_path / "run" / "report" / "prediction_errors.png").is_file()
    figure = subprocess.run(
        [sys.executable, "-m", "analysis.plot_run", str(tmp_path / "run"), "--trial", "1"],
        cwd=Path.cwd(), env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert figure.returncode == 0, figure.stderr[-2000:]
