"""The real runner, end to end, with tiny settings."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import torch
from omegaconf import OmegaConf

from analysis.summary import load_runs, markdown, resumed_after, wall_seconds
from mcpilco.errors import NotPositiveDefiniteError
from mcpilco.run_storage import RunDirectory
from mcpilco.tracking import read_run_log

ROOT = Path(__file__).resolve().parent.parent
TINY = [
    "num_trials=2",
    "threads=1",
    "compile=false",  # the compiled step has its own tests (tests/test_compiled_step.py)
    "optimizer.num_particles=8",
    "optimizer.max_steps=4",
    "optimizer.max_steps_first_trial=4",
    "policy.num_basis=10",
    "system.trial_duration=1.0",
]
ONE_TINY_TRIAL = [
    "num_trials=1",
    "threads=1",
    "compile=false",
    "optimizer.num_particles=8",
    "optimizer.max_steps=3",
    "optimizer.max_steps_first_trial=3",
    "policy.num_basis=10",
    "system.trial_duration=0.5",
]
"""One learning trial of a few steps on half a second: for checks of the whole loop."""


def run_module(module: str, *args: str, timeout: float = 600) -> subprocess.CompletedProcess[str]:
    """``python -m module args...`` from the repository root, output captured."""
    return subprocess.run(
        [sys.executable, "-m", module, *args],
        cwd=Path.cwd(),
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def run_train(*overrides: str) -> subprocess.CompletedProcess[str]:
    return run_module("runners.train", *overrides)


@pytest.mark.parametrize("kernel", ["sp"])
def test_smoke_run_writes_every_phase_and_artefact(tmp_path: Path, kernel: str) -> None:
    """The default (compiled) tiny run completes and records its phases; how long a run
    takes is measured by ``runners.bench_run``, not asserted here."""
    start = time.perf_counter()
    default_compile = [o for o in TINY if not o.startswith("compile=")]  # as users run it
    result = run_train(*default_compile, f"kernel={kernel}", f"hydra.run.dir={tmp_path}")
    elapsed = time.perf_counter() - start
    assert result.returncode == 0, result.stderr[-2000:]
    summary = pd.read_csv(tmp_path / "summary.csv")
    assert summary["trial"].tolist() == [0, 1, 2]
    assert summary.loc[1:, "optimization_steps"].tolist() == [4, 4]
    phases = {"fit_seconds", "optimization_seconds", "rollout_seconds", "logging_seconds"}
    assert {"eval_cost", "success"} | phases <= set(summary.columns)
    assert (summary[list(phases - {"fit_seconds", "optimization_seconds"})] > 0).all().all()
    assert summary[list(phases)].sum().sum() < elapsed  # the phases fit in the run's wall time
    # each trial's phases fit in its own wall time, and those in the run's
    assert (summary[list(phases)].fillna(0.0).sum(axis=1) <= summary["trial_seconds"]).all()
    assert summary["trial_seconds"].sum() < elapsed
    config = OmegaConf.load(tmp_path / "config.yaml")
    assert config.optimizer.num_particles == 8 and config.kernel.terms[0]._target_.endswith(
        "PhysicalBasis"
    )
    run = RunDirectory(tmp_path)
    policy = run.load_checkpoint(2, "policy")
    assert policy["centres"].shape == (10, 5)
    model = run.load_checkpoint(2, "model")
    assert model["train_inputs"].shape == (40, 6)  # 2 trajectories of 20 steps before trial 2
    trajectory = run.load_trajectory(2)
    assert trajectory.states.shape == (21, 4) and trajectory.actions.shape == (20, 1)
    trace = pd.read_csv(tmp_path / "optimization" / "trial_01.csv")
    assert list(trace.columns) == ["step", "cost", "dropout", "learning_rate", "signal", "horizon"]
    table = load_runs([tmp_path])
    tiny = "PI+SE [not the thesis's budget: M 8, N_opt T1 4, N_opt 4, n_b 10, T (s) 1]"
    assert table.loc[0, "kernel"] == tiny and table.loc[0, "trials_done"] == 2
    assert table.loc[0, "cost_T2"] == summary.loc[2, "eval_cost"]
    assert f"| {tiny} | 0 |" in markdown(table)


def test_bad_value_exits_with_one_line_error(tmp_path: Path) -> None:
    result = run_train("optimizer.num_particles=0", f"hydra.run.dir={tmp_path}")
    assert result.returncode == 2
    errors = [line for line in (result.stdout + result.stderr).splitlines() if "ERROR" in line]
    assert len(errors) == 1 and "optimizer.num_particles" in errors[0]
    assert not (tmp_path / "summary.csv").exists()


def test_unknown_option_shows_hydra_choices(tmp_path: Path) -> None:
    result = run_train("kernel=nope", f"hydra.run.dir={tmp_path}")
    assert result.returncode != 0
    assert "Available options" in result.stderr and "se_p2" in result.stderr


def test_failed_model_fit_names_the_trial_and_keeps_finished_trials(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from hydra import compose, initialize_config_dir

    from mcpilco.build import build
    from mcpilco.models.base import ModelStructure
    from mcpilco.trial_loop import TrialLoop

    with initialize_config_dir(version_base="1.3", config_dir=str(ROOT / "conf")):
        cfg = compose("train", overrides=TINY[:-1] + ["system.trial_duration=0.5"])
    experiment = build(cfg)
    calls = {"count": 0}
    original = ModelStructure.fit

    def failing_fit(self, states, actions):  # type: ignore[no-untyped-def]
        calls["count"] += 1
        if calls["count"] == 2:
            raise NotPositiveDefiniteError("GP outputs ['d_x1', 'd_x3']: not positive definite")
        return original(self, states, actions)

    monkeypatch.setattr(ModelStructure, "fit", failing_fit)
    loop = TrialLoop(experiment.components, RunDirectory(tmp_path), experiment.streams, 2)
    with pytest.raises(NotPositiveDefiniteError, match=r"trial 2: GP outputs \['d_x1', 'd_x3'\]"):
        loop.run()
    assert pd.read_csv(tmp_path / "summary.csv")["trial"].tolist() == [0, 1]
    assert (tmp_path / "checkpoints" / "trial_01" / "policy.pt").exists()
    torch.load(tmp_path / "checkpoints" / "trial_01" / "model.pt", weights_only=True)


def test_resume_continues_exactly_like_an_uninterrupted_run(tmp_path: Path) -> None:
    whole, part = tmp_path / "whole", tmp_path / "part"
    assert run_train(*TINY, f"hydra.run.dir={whole}").returncode == 0
    start = time.perf_counter()
    first = run_train(*TINY, "num_trials=1", f"hydra.run.dir={part}")
    assert first.returncode == 0
    time.sleep(1.0)  # the run stopped for a while before it was resumed
    resumed = run_train("num_trials=2", f"resume={part}", f"hydra.run.dir={tmp_path / 'other'}")
    both_processes = time.perf_counter() - start - 1.0
    assert resumed.returncode == 0, resumed.stderr[-2000:]
    # the resumed trial is logged in the run directory's own train.log, after trial 1
    lines = (part / "train.log").read_text().splitlines()
    first = [i for i, line in enumerate(lines) if re.search(r"\] - trial 1/\d+  cost ", line)]
    second = [i for i, line in enumerate(lines) if re.search(r"\] - trial 2/\d+  cost ", line)]
    assert len(first) == 1 and len(second) == 1 and first[0] < second[0]
    expected = pd.read_csv(whole / "summary.csv").drop(columns=["timestamp"])
    got = pd.read_csv(part / "summary.csv").drop(columns=["timestamp"])
    assert got["trial"].tolist() == [0, 1, 2]
    timing = [column for column in got.columns if column.endswith("_seconds")]
    pd.testing.assert_frame_equal(got.drop(columns=timing), expected.drop(columns=timing))
    # the wait before the resume (and the resumed process's start) is in no trial's time
    stamps = pd.read_csv(part / "summary.csv")["timestamp"]
    assert got.loc[2, "trial_seconds"] < stamps[2] - stamps[1] - 1.0
    assert 0 < wall_seconds(pd.read_csv(part / "summary.csv")) < both_processes
    assert resumed_after(part) == {1}
    assert 0 < load_runs([part]).loc[0, "wall_minutes"] * 60 < both_processes


def test_wall_time_of_a_run_skips_the_pause_before_a_resume(tmp_path: Path) -> None:
    """Rows of a run resumed after trial 2, 100 000 s later; the first rows were written
    before ``trial_seconds`` existed (time since the row before counts, or after a resume
    the row's recorded phases)."""
    nan = float("nan")
    rows = pd.DataFrame(
        {
            "trial": [0, 1, 2, 3],
            "timestamp": [1000.0, 1100.0, 1250.0, 101250.0],
            "fit_seconds": [nan, 2.0, 3.0, 4.0],
            "optimization_seconds": [nan, 90.0, 140.0, 280.0],
            "rollout_seconds": [0.5, 0.5, 0.5, 0.5],
        }
    )
    assert wall_seconds(rows) == 100250.0  # nothing tells the pause
    assert wall_seconds(rows, resumed=[2]) == 100.0 + 150.0 + 284.5
    rows["trial_seconds"] = [nan, nan, nan, 300.0]
    assert wall_seconds(rows, resumed=[2]) == wall_seconds(rows) == 100.0 + 150.0 + 300.0
    rows["trial_seconds"] = [5.0, 90.0, 140.0, 300.0]
    assert wall_seconds(rows) == 535.0
    # the resumes as the run's train.log records them
    (tmp_path / "train.log").write_text(
        "[2026-11-22 08:00:00,000][mcpilco.train][INFO] - run directory: /r\n"
        "[2026-12-06 11:38:38,352][mcpilco.trial_loop][INFO] - resuming /r after trial 2\n"
        "[2026-12-06 11:50:58,210][mcpilco.trial_loop][INFO] - trial 3: {'trial': 3}\n"
    )
    assert resumed_after(tmp_path) == {2} and resumed_after(tmp_path / "none") == set()


@pytest.mark.slow  # CI time (make test-slow runs it)
def test_rerun_in_a_used_directory_continues_only_the_same_experiment(tmp_path: Path) -> None:
    assert run_train(*TINY, "num_trials=1", f"hydra.run.dir={tmp_path}").returncode == 0
    same = run_train(*TINY, "num_trials=1", f"hydra.run.dir={tmp_path}")
    assert same.returncode == 0  # nothing left to do: finished jobs are skipped
    assert pd.read_csv(tmp_path / "summary.csv")["trial"].tolist() == [0, 1]
    other = run_train(*TINY, "num_trials=1", "kernel=sp", f"hydra.run.dir={tmp_path}")
    output = other.stderr + other.stdout
    assert other.returncode == 2 and "holds a train run made with kernel._target_=" in output


@pytest.mark.slow  # CI time (make test-slow runs it)
def test_partially_measured_run_logs_position_readings(tmp_path: Path) -> None:
    """MC-PILCO4PMS end to end: positions-only readings, Kalman estimator, MCAP + Rerun."""
    result = run_train(
        *TINY,
        "num_trials=1",
        "system.measured_indices=[0,2]",
        "estimator=kalman",
        "tracking.rerun=save",
        f"hydra.run.dir={tmp_path}",
    )
    assert result.returncode == 0, result.stderr[-2000:]
    trajectory = RunDirectory(tmp_path).load_trajectory(1)
    assert trajectory.measurements.shape == (21, 2) and trajectory.states.shape == (21, 4)
    np.testing.assert_allclose(trajectory.measurements, trajectory.states[:, [0, 2]], atol=0.05)
    log = read_run_log(tmp_path / "rollouts.mcap")
    assert {"measurement_0", "measurement_1"} <= set(log.rollouts.columns)
    assert "measurement_2" not in log.rollouts.columns
    evaluation = run_module("analysis.evaluate", str(tmp_path), "--runs", "4")
    assert evaluation.returncode == 0, evaluation.stderr[-2000:]
    result = json.loads((tmp_path / "evaluation" / "trial_01.json").read_text())
    assert result["runs"] == 4 and result["trial"] == 1 and result["simulate_estimator"]
    assert 0 <= result["system_successes"] <= 4 and 0 <= result["model_successes"] <= 4
    runs = result["system_runs"]
    assert len(runs) == 4 and sum(r["success"] for r in runs) == result["system_successes"]
    costs = [r["eval_cost"] for r in runs]
    assert result["system_metrics"]["eval_cost"] == {"mean": np.mean(costs), "max": max(costs)}
    assert all(len(r["initial_state"]) == 4 for r in runs)
    bad = run_module("analysis.evaluate", str(tmp_path), "--trial", "7")
    assert bad.returncode != 0 and "--trial=7" in bad.stderr
    # fixed starts (the multimodal test of thesis Fig. 2.9): one run from each cart position
    starts = run_module("analysis.evaluate", str(tmp_path), "--starts", "0=-1,0,1.5")
    assert starts.returncode == 0, starts.stderr[-2000:]
    outcome = json.loads((tmp_path / "evaluation" / "trial_01_starts.json").read_text())
    assert [s["start"] for s in outcome["starts"]] == [-1.0, 0.0, 1.5]
    assert [s["initial_state"] for s in outcome["starts"]] == [
        [-1.0, 0, 0, 0],
        [0.0, 0, 0, 0],
        [1.5, 0, 0, 0],
    ]
    assert all(isinstance(s["success"], bool) for s in outcome["starts"])
    assert (tmp_path / "evaluation" / "trial_01_starts.png").stat().st_size > 0
    bad = run_module("analysis.evaluate", str(tmp_path), "--starts", "9=1")
    assert bad.returncode != 0 and "--starts='9=1'" in bad.stderr


def test_derivative_free_run_learns_from_position_readings(tmp_path: Path) -> None:
    result = run_train(
        *TINY, "num_trials=1", "+experiment=cartpole_df", f"hydra.run.dir={tmp_path}"
    )
    assert result.returncode == 0, result.stderr[-2000:]
    model = RunDirectory(tmp_path).load_checkpoint(1, "model")
    # 30 steps at 30 Hz; GP input [p, sin θ, cos θ, Δq_{t-1} (2), Δq_{t-2} (2), u_t, u_{t-1}]
    assert model["train_inputs"].shape == (30, 9)
    assert model["train_targets"].shape == (30, 2)


def test_pytorch_warnings_reach_the_run_log(tmp_path: Path) -> None:
    """PyTorch's loggers do not propagate; the compiler's warnings (e.g. its graph limit,
    after which a step runs eagerly) must still reach train.log, not only the console."""
    import logging

    from runners.process import log_torch_warnings_to_files

    log_file = tmp_path / "train.log"
    handler = logging.FileHandler(log_file)
    root = logging.getLogger()
    root.addHandler(handler)
    try:
        log_torch_warnings_to_files()
        log_torch_warnings_to_files()  # idempotent: one line per warning
        logging.getLogger("torch._dynamo.convert_frame").warning("hit config.recompile_limit")
        logging.getLogger("torch._dynamo.convert_frame").debug("not a warning")
        trace = logging.getLogger("torch.__trace")  # logs at DEBUG on its own (level DEBUG)
        assert trace.isEnabledFor(logging.DEBUG)
        trace.debug("a compiler trace record")
    finally:
        for logger in [root, *map(logging.getLogger, list(logging.root.manager.loggerDict))]:
            logger.removeHandler(handler)
            for forward in [h for h in logger.handlers if getattr(h, "target", None) is handler]:
                logger.removeHandler(forward)
        handler.close()
    assert log_file.read_text().splitlines() == ["hit config.recompile_limit"]
