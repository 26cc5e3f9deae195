"""A run directory is used by one process at a time, and reading one runs nothing it names."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pandas as pd
import pytest
import torch
from omegaconf import OmegaConf
from synthetic_log import write_log

from mcpilco.errors import CheckpointError, RefusedTargetError, RunInUseError
from mcpilco.run_storage import RunDirectory
from mcpilco.safe_config import check_targets, config_from_text, locate_class
from mcpilco.systems import CartPole

ROOT = Path(__file__).resolve().parent.parent
TINY = [
    "num_trials=2",
    "threads=1",
    "compile=false",
    "optimizer.num_particles=8",
    "optimizer.max_steps=4",
    "optimizer.max_steps_first_trial=4",
    "policy.num_basis=10",
    "system.trial_duration=0.5",
]


def run_module(module: str, *args: str, env: dict[str, str] | None = None):  # type: ignore[no-untyped-def]
    return subprocess.run(
        [sys.executable, "-m", module, *args],
        cwd=Path.cwd(),
        capture_output=True,
        text=True,
        timeout=600,  # a hang guard, not a time limit
        env=env,
    )


def error_lines(result: subprocess.CompletedProcess[str]) -> list[str]:
    return [line for line in (result.stdout + result.stderr).splitlines() if "ERROR" in line]


# ----------------------------------------------------------------------------- the lock
def test_a_second_process_on_a_live_run_directory_is_refused(tmp_path: Path) -> None:
    with RunDirectory(tmp_path).locked():  # this process plays the live run
        result = run_module("runners.train", *TINY, f"hydra.run.dir={tmp_path}")
    assert result.returncode == 2
    errors = error_lines(result)
    assert len(errors) == 1 and f"{tmp_path} is in use by pid {os.getpid()}" in errors[0]
    assert not (tmp_path / "summary.csv").exists()
    assert not (tmp_path / "failed.txt").exists()  # the live run's directory is left alone


def test_a_killed_process_does_not_leave_the_lock_stuck(tmp_path: Path) -> None:
    holder = subprocess.Popen(
        [
            sys.executable,
            "-c",
            textwrap.dedent(
                f"""
                import time
                from mcpilco.run_storage import RunDirectory
                with RunDirectory({str(tmp_path)!r}).locked():
                    print("locked", flush=True)
                    time.sleep(600)
                """
            ),
        ],
        cwd=Path.cwd(),
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "locked"
        with pytest.raises(RunInUseError, match=f"in use by pid {holder.pid}"):
            with RunDirectory(tmp_path).locked():
                pass
    finally:
        holder.send_signal(signal.SIGKILL)
        holder.wait(timeout=60)
        holder.stdout.close()  # type: ignore[union-attr]
    with RunDirectory(tmp_path).locked():  # free again, without any clean-up
        assert (tmp_path / RunDirectory.LOCK_FILE).read_text().startswith(f"pid {os.getpid()}")


@pytest.mark.slow  # CI time (make test-slow runs it)
def test_two_runs_started_together_in_one_directory_never_mix(tmp_path: Path) -> None:
    """Issue 27: both exited 0, the summary held trials [0, 1, 1, 2, 2] and mixed seeds."""
    command = [sys.executable, "-m", "runners.train", *TINY, f"hydra.run.dir={tmp_path}"]
    runs = [
        subprocess.Popen(
            [*command, f"seed={seed}"],
            cwd=Path.cwd(),
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for seed in (0, 1)
    ]
    outputs = [run.communicate(timeout=600) for run in runs]
    codes = [run.returncode for run in runs]
    assert sorted(codes) == [0, 2], outputs
    winner = codes.index(0)
    loser_output = "".join(outputs[1 - winner])
    assert "is in use by" in loser_output or "holds a train run made with" in loser_output
    assert pd.read_csv(tmp_path / "summary.csv")["trial"].tolist() == [0, 1, 2]
    assert OmegaConf.load(tmp_path / "config.yaml").seed == winner


# --------------------------------------------------------------- what a config may name
class MyCartPole(CartPole):
    """A user's plug-in: a subclass of an extension point."""


@pytest.mark.parametrize(
    ("target", "reason"),
    [
        ("builtins.open", "standard library"),
        ("os.system", "standard library"),
        ("subprocess.Popen", "standard library"),
        ("torch.load", "not a class"),
        ("torch.nn.Linear", "derives from none of mcpilco's extension points"),
        ("mcpilco.run_storage.RunDirectory", "derives from none"),
        ("mcpilco.build.build", "not a class"),
        ("mcpilco.systems._private", "not a dotted path"),
        ("not_installed_anywhere.Plant", "no importable module"),
        ("mcpilco.systems.NoSuchPlant", "has no 'NoSuchPlant'"),
        (42, "not a dotted path"),
    ],
)
def test_targets_outside_the_extension_points_are_refused(target: object, reason: str) -> None:
    with pytest.raises(RefusedTargetError, match=reason) as error:
        check_targets({"system": {"_target_": target}})
    assert "system._target_=" in str(error.value) and "\n" not in str(error.value)


def test_our_classes_and_user_subclasses_are_allowed() -> None:
    assert locate_class("mcpilco.systems.CartPole") is CartPole
    assert locate_class(f"{__name__}.MyCartPole") is MyCartPole
    assert locate_class("mcpilco.tracking.RerunStreamer").__name__ == "RerunStreamer"
    check_targets(OmegaConf.load(ROOT / "conf" / "kernel" / "se_linear.yaml"))  # nested lists


@pytest.mark.slow  # CI time (make test-slow runs it)
def test_a_hostile_config_yaml_runs_nothing_when_evaluated(tmp_path: Path) -> None:
    """Issue 27: a config.yaml naming builtins.open with mode w truncated a file when
    analysis.evaluate read the directory."""
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    run = tmp_path / "run"
    assert (
        run_module("runners.train", *TINY, "num_trials=1", f"hydra.run.dir={run}").returncode == 0
    )
    config = OmegaConf.load(run / "config.yaml")
    config.system = {"_target_": "builtins.open", "file": str(victim), "mode": "w"}
    OmegaConf.save(config, run / "config.yaml")
    result = run_module("analysis.evaluate", str(run), "--runs", "2")
    assert result.returncode != 0
    assert victim.read_text() == "precious"
    last = result.stderr.strip().splitlines()[-1]
    assert "system._target_='builtins.open' is refused" in last
    resumed = run_module("runners.train", "num_trials=2", f"resume={run}")
    assert resumed.returncode == 2 and victim.read_text() == "precious"
    assert len(error_lines(resumed)) == 1 and "builtins.open" in error_lines(resumed)[0]
    # the directory can still be inspected as data
    summary = run_module("analysis.summary", str(run))
    assert summary.returncode == 0, summary.stderr[-2000:]


@pytest.mark.parametrize(
    "system",
    [
        "{_target_: builtins.open, file: VICTIM, mode: w}",
        pytest.param(  # slow: CI time
            "{_target_: not_installed_plugin.Pendulum, length: 1.0}", marks=pytest.mark.slow
        ),
    ],
)
def test_replay_of_a_foreign_log_runs_nothing_and_still_replays(
    tmp_path: Path, system: str
) -> None:
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    write_log(tmp_path, 2, f"system: {system.replace('VICTIM', str(victim))}\nseed: 0\n")
    result = run_module("runners.replay", str(tmp_path))
    assert result.returncode == 0, result.stderr[-2000:]
    assert victim.read_text() == "precious"
    warnings = [line for line in result.stderr.splitlines() if "cannot be built here" in line]
    assert len(warnings) == 1
    assert (tmp_path / "replay.rrd").stat().st_size > 1000


def test_config_text_that_is_not_a_mapping_fails_in_one_line() -> None:
    from mcpilco.errors import ConfigError

    with pytest.raises(ConfigError, match="not a config mapping"):
        config_from_text("- a\n- b\n", "somewhere")


# ---------------------------------------------------------------------------- resume
@pytest.mark.slow  # CI time (make test-slow runs it)
def test_resume_keeps_the_saved_number_of_trials(tmp_path: Path) -> None:
    assert (
        run_module("runners.train", *TINY, "num_trials=1", f"hydra.run.dir={tmp_path}").returncode
        == 0
    )
    again = run_module("runners.train", f"resume={tmp_path}", f"hydra.run.dir={tmp_path / 'x'}")
    assert again.returncode == 0, again.stderr[-2000:]
    assert pd.read_csv(tmp_path / "summary.csv")["trial"].tolist() == [0, 1]
    assert OmegaConf.load(tmp_path / "config.yaml").num_trials == 1
    longer = run_module(
        "runners.train", "num_trials=2", f"resume={tmp_path}", f"hydra.run.dir={tmp_path / 'y'}"
    )
    assert longer.returncode == 0, longer.stderr[-2000:]
    assert pd.read_csv(tmp_path / "summary.csv")["trial"].tolist() == [0, 1, 2]
    assert OmegaConf.load(tmp_path / "config.yaml").num_trials == 2


# ------------------------------------------------------------------------ checkpoints
class Payload:
    def __reduce__(self):  # type: ignore[no-untyped-def]
        return (os.system, ("echo pwned",))


def test_a_code_running_checkpoint_is_refused_naming_the_file(tmp_path: Path) -> None:
    run = RunDirectory(tmp_path)
    run.save_checkpoint(1, "policy", {"centres": torch.zeros(2, 3)})
    path = tmp_path / "checkpoints" / "trial_01" / "policy.pt"
    torch.save({"centres": Payload()}, path)
    with pytest.raises(CheckpointError) as error:
        run.load_checkpoint(1, "policy")
    message = str(error.value)
    assert str(path) in message and "refused" in message and "posix.system" in message
    assert "weights_only=False" not in message and "\n" not in message
    path.write_bytes(path.read_bytes()[:50])
    with pytest.raises(CheckpointError, match=f"{path} is not a readable checkpoint"):
        run.load_checkpoint(1, "policy")
    with pytest.raises(CheckpointError, match="trial_02.*does not exist"):
        run.load_checkpoint(2, "policy")


def test_ctrl_c_writes_failed_txt_and_keeps_finished_trials(tmp_path: Path) -> None:
    longer = [o for o in TINY if not o.startswith(("num_trials", "optimizer.max_steps"))]
    process = subprocess.Popen(
        [
            sys.executable, "-m", "runners.train", *longer, "num_trials=1000",
            "optimizer.max_steps=400", "optimizer.max_steps_first_trial=400",
            f"hydra.run.dir={tmp_path}",
        ],
        cwd=Path.cwd(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        # a shell's background job (e.g. `.ci/run &`) ignores SIGINT, and the child would
        # inherit that: Ctrl-C is what is tested, so the child gets the default handler
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )  # fmt: skip
    try:
        summary = tmp_path / "summary.csv"
        deadline = time.monotonic() + 300
        while not (summary.is_file() and len(pd.read_csv(summary)) >= 2):
            assert process.poll() is None and time.monotonic() < deadline, process.communicate()
            time.sleep(0.2)
        assert process.poll() is None  # 1000 trials: still running when the signal comes
        process.send_signal(signal.SIGINT)
        stdout, stderr = process.communicate(timeout=300)
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
    assert process.returncode == 130, stderr[
        -2000:
    ]  # 128 + SIGINT, without a traceback on the console
    assert "interrupted; the finished trials are kept" in stdout + stderr
    assert "Traceback" not in stdout + stderr
    assert "KeyboardInterrupt" in (tmp_path / "failed.txt").read_text()
    finished = pd.read_csv(summary)["trial"].tolist()
    assert finished[:2] == [0, 1] and finished == list(range(len(finished)))


@pytest.mark.slow  # CI time (make test-slow runs it)
def test_a_sweep_report_skips_a_refused_run_and_reports_the_others(tmp_path: Path) -> None:
    """analysis.report builds each run's model for the prediction errors: a hostile run is
    skipped with a warning, the other runs are reported, nothing it names runs."""
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    for name in ("good", "hostile"):
        result = run_module(
            "runners.train", *TINY, "num_trials=1", f"hydra.run.dir={tmp_path / name}"
        )
        assert result.returncode == 0, result.stderr[-2000:]
    config = OmegaConf.load(tmp_path / "hostile" / "config.yaml")
    config.system = {"_target_": "builtins.open", "file": str(victim), "mode": "w"}
    OmegaConf.save(config, tmp_path / "hostile" / "config.yaml")
    report = run_module("analysis.report", str(tmp_path), "--out", str(tmp_path / "report"))
    assert report.returncode == 0, report.stderr[-2000:]
    assert victim.read_text() == "precious"
    assert "no prediction errors for" in report.stderr and "builtins.open" in report.stderr
    assert (tmp_path / "report" / "prediction_errors.csv").is_file()
