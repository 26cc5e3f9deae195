"""A seed sweep through ``hydra/launcher=ray`` against a real local Ray cluster: a head and a
worker node (``ray start``) on 127.0.0.1, one CPU each. Every job gets its run directory, the
failing jobs leave ``failed.txt`` while the others finish, and the re-submitted sweep skips
the finished jobs. Skipped without ``ray`` (``pip install -e '.[ray]'``)."""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pandas as pd
import pytest

from tests.test_runner import run_module
from tests.test_sweeps import TINY_SWEEP

pytest.importorskip("ray")
pytestmark = pytest.mark.slow  # about 1.5 min: two Ray nodes start, then two sweeps

RAY = str(Path(sys.executable).parent / "ray")
NODE = ["--node-ip-address=127.0.0.1", "--num-cpus=1", "--object-store-memory=100000000"]
SWEEP = [
    *TINY_SWEEP[:-2],  # the local sweep test's tiny runs, without its seed and kernel axes
    "hydra/launcher=ray",
    "seed=0,1",
    "system.dt=0.05,-0.05",  # the two jobs with dt < 0 fail before any work
]


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def processes_mentioning(text: str) -> list[int]:
    found = []
    for cmdline in Path("/proc").glob("[0-9]*/cmdline"):
        try:
            if text.encode() in cmdline.read_bytes():
                found.append(int(cmdline.parent.name))
        except OSError:
            continue
    return found


def start_node(*arguments: str, env: dict[str, str]) -> subprocess.Popen[bytes]:
    return subprocess.Popen(
        [RAY, "start", *arguments, *NODE, "--disable-usage-stats", "--block"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env, start_new_session=True,
    )  # fmt: skip


def wait_for_nodes(address: str, count: int, env: dict[str, str], timeout: float = 120) -> None:
    deadline = time.monotonic() + timeout
    status = ""
    while time.monotonic() < deadline:
        status = subprocess.run(
            [RAY, "status", f"--address={address}"], capture_output=True, text=True, env=env
        ).stdout
        if status.count(" node_") >= count and "Pending:\n (no pending nodes)" in status:
            return
        time.sleep(2)
    raise TimeoutError(f"the Ray cluster at {address} did not show {count} nodes:\n{status}")


@pytest.fixture()
def ray_cluster() -> Iterator[str]:
    """A head and a worker node on 127.0.0.1; yields the head's address; stops both."""
    temp = tempfile.mkdtemp(prefix="ray", dir="/tmp")  # short: Ray's socket paths are limited
    env = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0"}
    address = f"127.0.0.1:{free_port()}"
    port = address.split(":")[1]
    nodes = [start_node("--head", f"--port={port}", "--include-dashboard=false",
                        f"--temp-dir={temp}", env=env)]  # fmt: skip
    try:
        wait_for_nodes(address, 1, env)
        nodes.append(start_node(f"--address={address}", env=env))
        wait_for_nodes(address, 2, env)
        yield address
    finally:
        for node in reversed(nodes):
            try:
                os.killpg(node.pid, signal.SIGTERM)
            except ProcessLookupError:
                pass
        for node in nodes:
            try:
                node.wait(30)
            except subprocess.TimeoutExpired:
                os.killpg(node.pid, signal.SIGKILL)
        deadline = time.monotonic() + 30
        while processes_mentioning(temp) and time.monotonic() < deadline:
            time.sleep(1)
        left = processes_mentioning(temp)
        for pid in left:
            os.kill(pid, signal.SIGKILL)
        shutil.rmtree(temp, ignore_errors=True)
        assert not left, f"Ray processes left behind: {left}"


def test_ray_cluster_sweep_runs_every_job_records_failures_and_skips_when_resubmitted(
    ray_cluster: str, tmp_path: Path
) -> None:
    command = [*SWEEP, f"hydra.launcher.address={ray_cluster}", f"hydra.sweep.dir={tmp_path}"]
    started = time.monotonic()
    first = run_module("runners.train", *command, timeout=600)
    seconds = time.monotonic() - started
    assert first.returncode != 0  # the sweep reports its failed jobs at the end
    assert "(_run_in_worker pid=" in first.stdout + first.stderr  # the jobs ran as Ray tasks
    failed = sorted(p.parent.name for p in tmp_path.glob("*/failed.txt"))
    finished = sorted(p.parent.name for p in tmp_path.glob("*/summary.csv"))
    assert len(failed) == 2 and all("system.dt=-0.05" in name for name in failed)
    assert "system.dt must be positive" in (tmp_path / failed[0] / "failed.txt").read_text()
    assert len(finished) == 2 and all("system.dt=0.05" in name for name in finished)
    assert {f"seed={s}" for s in (0, 1)} == {
        part for name in finished for part in name.split(",") if part.startswith("seed=")
    }
    for name in finished:
        assert pd.read_csv(tmp_path / name / "summary.csv")["trial"].tolist() == [0, 1]
        assert (tmp_path / name / "rollouts.mcap").stat().st_size > 0
    stamps = {name: (tmp_path / name / "summary.csv").stat().st_mtime_ns for name in finished}

    again = run_module("runners.train", *command, timeout=600)
    assert again.returncode != 0
    assert "continuing the finished trials" in again.stderr + again.stdout
    for name in finished:  # nothing recomputed
        assert (tmp_path / name / "summary.csv").stat().st_mtime_ns == stamps[name]
    print(f"first sweep: {seconds:.1f} s wall (4 jobs, 2 Ray nodes x 1 CPU)")
