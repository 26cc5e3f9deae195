"""MCAP log of a real run: contents, a SIGKILL mid-trial, and resume exactly once."""

from __future__ import annotations

import gc
import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from mcap.reader import make_reader
from omegaconf import OmegaConf
from synthetic_log import write_log

from analysis.calibrate import calibrate
from analysis.plot_run import plot_trial
from mcpilco.run_storage import RunDirectory
from mcpilco.tracking import read_run_log

ROOT = Path(__file__).resolve().parent.parent
TINY = [
    "threads=1",
    "compile=false",  # the compiled step has its own tests (tests/test_compiled_step.py)
    "optimizer.num_particles=60",
    "policy.num_basis=10",
    "system.trial_duration=1.0",
    "optimizer.max_steps_first_trial=3",
]


def train_command(*overrides: str) -> list[str]:
    return [sys.executable, "-m", "runners.train", *overrides]


def test_log_holds_every_rollout_and_the_metadata(tmp_path: Path) -> None:
    result = subprocess.run(
        train_command(*TINY, "num_trials=2", "optimizer.max_steps=3", f"hydra.run.dir={tmp_path}"),
        cwd=Path.cwd(),
        capture_output=True,
        text=True,
        timeout=600,  # a hang guard, not a time limit (a loaded machine is slow)
    )
    assert result.returncode == 0, result.stderr[-2000:]
    # The plain mcap reader (summary section present: the run ended normally).
    with open(tmp_path / "rollouts.mcap", "rb") as handle:
        reader = make_reader(handle)
        topics = {c.topic for c in reader.get_summary().channels.values()}
        metadata = [m for m in reader.iter_metadata() if m.name == "run"]
    assert {"/rollout", "/particles", "/optimization", "/gp/hyperparameters", "/trial"} <= topics
    config = OmegaConf.create(metadata[0].metadata["config"])
    assert config.optimizer.num_particles == 60 and config.seed == 0
    assert "torch" in json.loads(metadata[0].metadata["versions"])

    log = read_run_log(tmp_path)
    run = RunDirectory(tmp_path)
    summary = run.summary()
    for trial in (0, 1, 2):
        rollout = log.rollout(trial)
        trajectory = run.load_trajectory(trial)
        assert len(rollout) == 21  # T + 1 samples of a 1 s trial at 0.05 s
        states = rollout[[f"state_{i}" for i in range(4)]].to_numpy()
        np.testing.assert_array_equal(states, trajectory.states)
        np.testing.assert_array_equal(rollout["action_0"].to_numpy()[:-1], trajectory.actions[:, 0])
        assert rollout["eval_cost"].sum() == summary.loc[trial, "eval_cost"]
    assert log.trials["trial"].tolist() == [0, 1, 2]
    # the calibration figures of the learning trials, as in summary.csv (per component too)
    for column in ("coverage_mean", "nll_mean", "coverage_p", "nll_θ̇"):
        assert summary[column].iloc[1:].notna().all()
    np.testing.assert_allclose(log.trials["coverage_mean"][1:], summary["coverage_mean"][1:])
    np.testing.assert_allclose(log.trials["coverage_0"][1:], summary["coverage_p"][1:])
    np.testing.assert_allclose(log.trials["nll_3"][1:], summary["nll_θ̇"][1:])
    # recomputed afterwards from the checkpoints (analysis.calibrate): same figures' kinds,
    # from a fresh draw of particles
    again = calibrate(tmp_path, 2, particles=500, seed=1)
    assert again["trial"] == 2 and 0.0 <= again["coverage_mean"] <= 1.0
    assert {k for k in again if k.startswith(("coverage_", "nll_"))} == {
        k for k in summary.columns if k.startswith(("coverage_", "nll_"))
    }
    assert (tmp_path / "evaluation" / "trial_02_calibration.json").is_file()
    assert log.particles[2]["states"].shape == (21, 60, 4)
    assert len(log.optimization) == 6 and not log.truncated
    assert log.optimization["horizon"].tolist() == [20] * 6  # no curriculum: the whole trial
    figure = plot_trial(log, 2)
    figure.savefig(tmp_path / "particles.png")
    assert (tmp_path / "particles.png").stat().st_size > 10_000


def wait_for(condition, timeout: float) -> None:  # type: ignore[no-untyped-def]
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.2)


def finished_trials(path: Path) -> list[int]:
    summary = path / "summary.csv"
    return pd.read_csv(summary)["trial"].tolist() if summary.exists() else []


@pytest.mark.slow  # CI time (make test-slow runs it)
def test_sigkill_mid_trial_then_resume_keeps_each_trial_once(tmp_path: Path) -> None:
    run_dir = tmp_path / "run"
    slow_trial_2 = [
        "num_trials=2",
        "optimizer.max_steps=600",  # trial 2 (~6 s idle) runs long enough to be killed inside it
        "optimizer.schedule.window=100000",
    ]
    process = subprocess.Popen(
        train_command(*TINY, *slow_trial_2, f"hydra.run.dir={run_dir}"),
        cwd=Path.cwd(),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        wait_for(lambda: finished_trials(run_dir) == [0, 1], timeout=240)
        time.sleep(2.0)  # inside trial 2's optimisation
        assert process.poll() is None
        process.send_signal(signal.SIGKILL)
        process.wait(timeout=10)
    finally:
        process.kill()
    killed = read_run_log(run_dir)
    assert killed.trials["trial"].tolist() == [0, 1]
    assert sorted(killed.rollouts["trial"].unique()) == [0, 1]
    assert all(len(killed.rollout(t)) == 21 for t in (0, 1))
    assert sorted(killed.particles) == [1]

    resumed = subprocess.run(
        train_command("num_trials=2", f"resume={run_dir}", f"hydra.run.dir={tmp_path / 'h'}"),
        cwd=Path.cwd(),
        capture_output=True,
        text=True,
        timeout=400,
    )
    assert resumed.returncode == 0, resumed.stderr[-2000:]
    log = read_run_log(run_dir)
    assert log.trials["trial"].tolist() == [0, 1, 2]
    assert log.rollouts.groupby("trial").size().tolist() == [21, 21, 21]
    assert sorted(log.particles) == [1, 2]
    assert log.optimization.groupby("trial").size().loc[1] == 3
    assert finished_trials(run_dir) == [0, 1, 2]
    assert [m["resumed_after_trial"] for m in log.metadata] == ["1"]


def particle_values(recording: Path, trial: int) -> int:
    from rerun.chunk import RrdReader

    total = 0
    for chunk in RrdReader(recording).store().stream():
        batch = chunk.to_record_batch()
        if str(chunk.entity_path) == f"/trial_{trial}/particles/x0" and (
            "Scalars:scalars" in batch.schema.names  # not the static line style
        ):
            total += sum(len(v) for v in batch.column("Scalars:scalars").to_pylist())
    return total


def blueprint_names(recording: Path) -> list[tuple[set[str], set[str]]]:
    """Per blueprint in the recording: its containers' and views' names, and the time
    panel's timeline."""
    from rerun.chunk import RrdReader

    reader = RrdReader(recording)
    found = []
    for entry in reader.blueprints():
        names, timelines = set(), set()
        for chunk in reader.store(store=entry).stream():
            batch = chunk.to_record_batch()
            for column in batch.schema.names:
                if column.endswith(":display_name"):
                    names.update(v for row in batch.column(column).to_pylist() for v in row)
                if column == "TimePanelBlueprint:timeline":
                    timelines.update(v for row in batch.column(column).to_pylist() for v in row)
        found.append((names, timelines))
    return found


def test_rerun_recording_and_replay_verify_and_hold_the_particles(tmp_path: Path) -> None:
    result = subprocess.run(
        train_command(
            *TINY,
            "num_trials=1",
            "optimizer.max_steps=3",
            "tracking.rerun=save",
            "tracking.rerun_stream.max_particles=60",
            f"hydra.run.dir={tmp_path}",
        ),
        cwd=Path.cwd(),
        capture_output=True,
        text=True,
        timeout=600,  # a hang guard, not a time limit (a loaded machine is slow)
    )
    assert result.returncode == 0, result.stderr[-2000:]
    replayed = subprocess.run(
        [sys.executable, "-m", "runners.replay", str(tmp_path), "--save", str(tmp_path / "r.rrd")],
        cwd=Path.cwd(),
        capture_output=True,
        text=True,
        timeout=600,  # a hang guard, not a time limit (a loaded machine is slow)
    )
    assert replayed.returncode == 0, replayed.stderr[-2000:]
    rerun = Path(sys.executable).parent / "rerun"
    for recording in (tmp_path / "recording.rrd", tmp_path / "r.rrd"):
        verify = subprocess.run(
            [str(rerun), "rrd", "verify", str(recording)],
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert verify.returncode == 0, verify.stderr[-1000:]
        assert particle_values(recording, 1) == 60 * 21  # M particles × (T + 1) steps
        # the blueprint sent after the last trial (the stores are not in send order: the one
        # naming the most): a tab per trial, config, time panel on time
        names, timelines = max(blueprint_names(recording), key=lambda found: len(found[0]))
        assert {"trial 0", "trial 1", "optimisation", "config", "system"} <= names
        assert timelines == {"time"}


def test_replay_of_a_missing_trial_fails_clearly(tmp_path: Path) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "runners.replay", str(tmp_path)],
        cwd=Path.cwd(),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2 and "no MCAP log" in result.stderr


def test_a_file_that_is_not_mcap_fails_clearly(tmp_path: Path) -> None:
    import pytest

    (tmp_path / "rollouts.mcap").write_bytes(b"definitely not an mcap file" * 10)
    with pytest.raises(ValueError, match="not an MCAP file"):
        read_run_log(tmp_path)


def test_truncated_anywhere_reads_a_prefix_of_whole_trials(tmp_path: Path) -> None:
    write_log(tmp_path, 4, steps=20)
    data = (tmp_path / "rollouts.mcap").read_bytes()
    previous = -1
    for fraction in np.linspace(0.02, 0.98, 25):
        cut = tmp_path / "cut.mcap"
        cut.write_bytes(data[: int(len(data) * fraction)])
        log = read_run_log(cut)
        trials = log.trials["trial"].tolist() if len(log.trials) else []
        assert trials == list(range(len(trials))) and log.truncated
        assert all(len(log.rollout(t)) == 21 for t in trials)
        assert len(trials) >= previous  # more bytes never lose a trial
        previous = len(trials)
    assert previous >= 3


def test_a_resumed_run_adds_a_recording_part_and_its_blueprint_keeps_the_earlier_trials(
    tmp_path: Path,
) -> None:
    from mcpilco.tracking import RerunStreamer
    from mcpilco.tracking.rerun_stream import recording_parts
    from mcpilco.trajectory import Trajectory

    states = np.zeros((11, 2))
    trajectory = Trajectory(states, states, np.zeros((10, 1)), 0.1)
    first = RerunStreamer(tmp_path)
    first.run_started({}, -1)
    for trial in (0, 1):
        first.rollout(trial, trajectory, np.zeros(11), np.zeros(11))
    first.close()
    size = (tmp_path / "recording.rrd").stat().st_size
    resumed = RerunStreamer(tmp_path)  # a resume after trial 1
    resumed.run_started({}, 1)
    resumed.rollout(2, trajectory, np.zeros(11), np.zeros(11))
    resumed.close()
    assert recording_parts(tmp_path) == [tmp_path / "recording.rrd", tmp_path / "recording.1.rrd"]
    assert (tmp_path / "recording.rrd").stat().st_size == size  # the first part is untouched
    names, _ = max(blueprint_names(tmp_path / "recording.1.rrd"), key=lambda f: len(f[0]))
    assert {"trial 0", "trial 1", "trial 2"} <= names


@pytest.mark.filterwarnings("error")  # an unclosed file warns (ResourceWarning) when freed
def test_closing_the_log_closes_its_file_and_leaves_a_whole_mcap(tmp_path: Path) -> None:
    write_log(tmp_path, trials=2)
    gc.collect()  # a file left open by the logger would be freed (and warn) here
    data = (tmp_path / "rollouts.mcap").read_bytes()
    assert data[:8] == data[-8:] == b"\x89MCAP0\r\n"  # header and trailing magic on disk
    assert len(read_run_log(tmp_path).trials) == 2
