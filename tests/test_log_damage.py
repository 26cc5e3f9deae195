"""The MCAP log against kills at the worst moment and damaged bytes: what is whole is read."""

from __future__ import annotations

import struct
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from mcap.reader import make_reader
from synthetic_log import write_log

from mcpilco.run_storage import RunDirectory
from mcpilco.tracking import read_run_log

ROOT = Path(__file__).resolve().parent.parent
TINY = [
    "threads=1",
    "compile=false",
    "optimizer.num_particles=50",
    "optimizer.max_steps=3",
    "optimizer.max_steps_first_trial=3",
    "policy.num_basis=10",
    "system.trial_duration=0.5",
]

KILLING_TRAIN = """
import os, signal, sys
from mcpilco.run_storage import RunDirectory

original = RunDirectory.append_summary

def append_summary(self, row):
    if row["trial"] == 2 and {when!r} == "before":
        os.kill(os.getpid(), signal.SIGKILL)
    table = original(self, row)
    if row["trial"] == 2 and {when!r} == "after":
        os.kill(os.getpid(), signal.SIGKILL)
    return table

RunDirectory.append_summary = append_summary
from runners.train import main
sys.argv = ["train", *{overrides!r}]
main()
"""


def run(code_or_module: list[str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, *code_or_module],
        cwd=Path.cwd(),
        capture_output=True,
        text=True,
        timeout=600,  # a hang guard, not a time limit
    )


def logged_trials(path: Path) -> list[int]:
    return read_run_log(path).trials["trial"].tolist()


@pytest.mark.parametrize("when", ["before", pytest.param("after", marks=pytest.mark.slow)])
def test_a_kill_around_the_summary_row_never_loses_a_finished_trial_from_the_log(
    tmp_path: Path, when: str
) -> None:
    """Issue 27: a kill between the summary row and the MCAP flush left the trial in the
    summary but never in the log (summary 0..3, log [0, 1, 3])."""
    overrides = [*TINY, "num_trials=3", f"hydra.run.dir={tmp_path}"]
    killed = run(["-c", textwrap.dedent(KILLING_TRAIN.format(when=when, overrides=overrides))])
    assert killed.returncode == -9, killed.stderr[-2000:]
    finished = pd.read_csv(tmp_path / "summary.csv")["trial"].tolist()
    assert finished == ([0, 1] if when == "before" else [0, 1, 2])
    assert set(finished) <= set(logged_trials(tmp_path))  # every finished trial is logged
    resumed = run(["-m", "runners.train", "num_trials=3", f"resume={tmp_path}"])
    assert resumed.returncode == 0, resumed.stderr[-2000:]
    assert pd.read_csv(tmp_path / "summary.csv")["trial"].tolist() == [0, 1, 2, 3]
    log = read_run_log(tmp_path)
    assert log.trials["trial"].tolist() == [0, 1, 2, 3]  # each exactly once
    for trial in range(4):
        states = log.rollout(trial)[[f"state_{i}" for i in range(4)]].to_numpy()
        np.testing.assert_array_equal(states, RunDirectory(tmp_path).load_trajectory(trial).states)


def chunk_offsets(path: Path) -> list[int]:
    """Start of each chunk record, from the file's own chunk index (the mcap package)."""
    with open(path, "rb") as handle:
        summary = make_reader(handle).get_summary()
    assert summary is not None
    return sorted(index.chunk_start_offset for index in summary.chunk_indexes)


@pytest.mark.parametrize(
    "damaged", [0, pytest.param(1, marks=pytest.mark.slow), pytest.param(3, marks=pytest.mark.slow)]
)
def test_a_chunk_length_of_two_to_the_forty_skips_that_chunk_only(
    tmp_path: Path, damaged: int
) -> None:
    """Issue 27: a bare MemoryError, and every trial behind the bad chunk dropped. Chunk 0
    also holds the channel definitions."""
    write_log(tmp_path, 4)
    path = tmp_path / "rollouts.mcap"
    data = bytearray(path.read_bytes())
    offsets = chunk_offsets(path)
    assert len(offsets) == 4  # one chunk per trial
    struct.pack_into("<Q", data, offsets[damaged] + 1, 2**40)
    path.write_bytes(bytes(data))
    log = read_run_log(path)
    assert log.trials["trial"].tolist() == [t for t in range(4) if t != damaged]
    assert len(log.problems) == 1 and f"byte {offsets[damaged]}" in log.problems[0]
    assert "\n" not in log.problems[0]
    assert all(len(log.rollout(t)) == 11 for t in log.trials["trial"])
    assert log.metadata and log.metadata[0]["config"] == "seed: 0"
    replay = run(["-m", "runners.replay", str(tmp_path)])
    assert replay.returncode == 0, replay.stderr[-2000:]
    assert "is damaged" in replay.stderr and (tmp_path / "replay.rrd").is_file()


def test_flipped_bytes_inside_a_chunk_skip_that_chunk_only(tmp_path: Path) -> None:
    write_log(tmp_path, 4)
    path = tmp_path / "rollouts.mcap"
    data = bytearray(path.read_bytes())
    offsets = chunk_offsets(path)
    middle = (offsets[2] + offsets[3]) // 2  # inside chunk 2's compressed data
    data[middle : middle + 8] = bytes(255 - b for b in data[middle : middle + 8])
    path.write_bytes(bytes(data))
    log = read_run_log(path)
    assert log.trials["trial"].tolist() == [0, 1, 3]
    assert len(log.problems) == 1 and "chunk" in log.problems[0]


def test_random_garbage_after_the_magic_reads_nothing_without_error(tmp_path: Path) -> None:
    path = tmp_path / "rollouts.mcap"
    rng = np.random.default_rng(1)
    for _ in range(20):
        path.write_bytes(b"\x89MCAP0\r\n" + rng.bytes(int(rng.integers(1, 5000))))
        log = read_run_log(path)  # never raises, never allocates what a length claims
        assert len(log.trials) == 0
