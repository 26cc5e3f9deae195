"""One run-directory contract for the three runners (issue 53): each numbered defect of the
issue reproduced as a user meets it, through the commands themselves."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
from omegaconf import OmegaConf
from synthetic_log import write_log

TRAIN_TINY = [
    "num_trials=1", "threads=1", "compile=false", "optimizer.num_particles=8",
    "optimizer.max_steps=3", "optimizer.max_steps_first_trial=3", "policy.num_basis=10",
    "system.trial_duration=0.5",
]  # fmt: skip
CGPDM_TINY = [
    "data.num_sequences=5", "data.num_test=2", "data.num_train=2", "excitation.num_samples=8",
    "train.steps=1", "train.iterations_per_step=5", "cloth.timestep=0.001",
    "cloth.edge_timeconst=0.002", "threads=1",
]  # fmt: skip
CONTROL_TINY = [
    "data.duration=2.0", "gp.fit_points=100", "gp.max_iterations=5", "reference.duration=0.3",
    "task.settle=0.2", "threads=1", "controller=gp_fl",
]  # fmt: skip

SLOW = pytest.mark.slow
"""End-to-end cases beside a faster one of the same guarantee (make test-slow)."""


def run(module: str, *args: str, env: dict[str, str] | None = None):  # type: ignore[no-untyped-def]
    return subprocess.run(
        [sys.executable, "-m", module, *args],
        cwd=Path.cwd(), capture_output=True, text=True, timeout=600, env=env,
    )  # fmt: skip


def output(result: subprocess.CompletedProcess[str]) -> str:
    return result.stdout + result.stderr


def errors(result: subprocess.CompletedProcess[str]) -> list[str]:
    return [line for line in output(result).splitlines() if "ERROR" in line]


def listing(path: Path) -> dict[str, int]:
    return {str(p.relative_to(path)): p.stat().st_mtime_ns for p in path.rglob("*")}


@pytest.fixture(scope="module")
def cgpdm_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished tiny cgpdm run (its data cache beside it), copied by the tests."""
    root = tmp_path_factory.mktemp("cgpdm")
    result = subprocess.run(
        [sys.executable, "-m", "runners.cgpdm", *CGPDM_TINY, f"data.dir={root / 'data'}",
         f"hydra.run.dir={root / 'run'}"],
        cwd=root, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr[-3000:]
    return root


@pytest.fixture(scope="module")
def train_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("train")
    result = subprocess.run(
        [sys.executable, "-m", "runners.train", *TRAIN_TINY, f"hydra.run.dir={root / 'run'}"],
        cwd=root, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr[-3000:]
    return root / "run"


# ------------------------------------------- 1. nothing of a run directory ever runs
PAYLOAD = """
from pathlib import Path
Path({marker!r}).write_text("payload ran")
from mcpilco.systems import CartPole
class X(CartPole):
    pass
"""


@pytest.mark.parametrize(
    "packages",
    [
        pytest.param(False, id="plain folders"),
        pytest.param(True, id="with __init__", marks=pytest.mark.slow),  # slow: CI time
    ],
)
def test_a_payload_beside_a_run_never_runs(tmp_path: Path, train_run: Path, packages: bool) -> None:
    """A run copied to docs/results/r of the working directory, naming a payload module
    beside it: evaluate, resume and replay refuse it in one line and the payload never
    writes its file, whether the folders import as namespace or as regular packages."""
    run_dir = tmp_path / "docs" / "results" / "r"
    shutil.copytree(train_run, run_dir, ignore=shutil.ignore_patterns(".mcpilco.lock"))
    marker = tmp_path / "PAYLOAD_RAN"
    (run_dir / "payload.py").write_text(PAYLOAD.format(marker=str(marker)))
    if packages:
        for folder in (tmp_path / "docs", tmp_path / "docs" / "results", run_dir):
            (folder / "__init__.py").write_text("")
    config = OmegaConf.load(run_dir / "config.yaml")
    config.system._target_ = "docs.results.r.payload.X"
    OmegaConf.save(config, run_dir / "config.yaml")
    evaluated = run("analysis.evaluate", "docs/results/r", "--runs", "1")
    assert evaluated.returncode != 0 and "is refused" in output(evaluated)
    resumed = run("runners.train", "resume=docs/results/r", "num_trials=2")
    assert resumed.returncode == 2 and len(errors(resumed)) == 1
    assert "docs.results.r.payload.X" in errors(resumed)[0]
    write_log(run_dir, 1, "system: {_target_: docs.results.r.payload.X}\nseed: 0\n")
    replayed = run("runners.replay", "docs/results/r")
    assert replayed.returncode == 0 and "cannot be built here" in output(replayed)
    assert not marker.exists()


def test_a_plug_in_put_on_pythonpath_on_purpose_still_loads(tmp_path: Path) -> None:
    plugins = tmp_path / "plugins"
    plugins.mkdir()
    (plugins / "my_plant.py").write_text(PAYLOAD.format(marker=str(tmp_path / "loaded")))
    probe = "from mcpilco.safe_config import locate_class; print(locate_class('my_plant.X'))"
    where = {**os.environ, "PYTHONPATH": str(plugins)}
    result = subprocess.run(
        [sys.executable, "-c", probe], cwd=plugins, capture_output=True, text=True, env=where
    )
    assert result.returncode == 0 and "my_plant.X" in result.stdout, result.stderr
    refused = subprocess.run(  # the same file, importable only as the working directory
        [sys.executable, "-c", probe], cwd=plugins, capture_output=True, text=True,
        env={k: v for k, v in os.environ.items() if k != "PYTHONPATH"},
    )  # fmt: skip
    assert refused.returncode != 0 and "lies in the working directory" in refused.stderr
    below = subprocess.run(  # a PYTHONPATH folder below the working directory is explicit too
        [sys.executable, "-c", probe], cwd=tmp_path, capture_output=True, text=True, env=where
    )
    assert below.returncode == 0 and "my_plant.X" in below.stdout, below.stderr
    (tmp_path / "loaded").unlink()
    assert not (tmp_path / "loaded").exists()


# --------------------------------- 2. a cgpdm directory is continued by its own config only
def test_cgpdm_refuses_a_stale_model_under_another_config(tmp_path: Path, cgpdm_run: Path) -> None:
    run_dir = tmp_path / "run"
    shutil.copytree(cgpdm_run / "run", run_dir)
    data = f"data.dir={cgpdm_run / 'data'}"
    (run_dir / "summary.csv").unlink()  # as if killed after model.pt
    other = run(
        "runners.cgpdm", *CGPDM_TINY, data, f"hydra.run.dir={run_dir}", "data.range_deg=120"
    )
    assert other.returncode == 2 and len(errors(other)) == 1
    assert "made with data.range_deg=30" in errors(other)[0] and "120" in errors(other)[0]
    assert not (run_dir / "summary.csv").exists()
    same = run("runners.cgpdm", *CGPDM_TINY, data, f"hydra.run.dir={run_dir}")
    assert same.returncode == 0 and "loaded the model trained here before" in output(same)
    variant = run("runners.cgpdm", *CGPDM_TINY, data, f"hydra.run.dir={run_dir}", "cgpdm=low")
    assert variant.returncode == 2 and "holds a cgpdm run made with" in errors(variant)[0]
    drawn = run("runners.cgpdm", *CGPDM_TINY, data, f"hydra.run.dir={run_dir}", "seed=1")
    assert drawn.returncode == 2 and "made with seed=0" in errors(drawn)[0]
    replaced = run(
        "runners.cgpdm", *CGPDM_TINY, data, f"hydra.run.dir={run_dir}", "seed=1", "overwrite=true"
    )
    assert replaced.returncode == 0, replaced.stderr[-2000:]
    assert json.loads((run_dir / "training_set.json").read_text())["draw"] == 1


# ------------------------------------------ 3. control: a rerun never duplicates a row
def test_control_rerun_skips_finished_seeds_and_never_duplicates(tmp_path: Path) -> None:
    models, run_dir = f"model_dir={tmp_path / 'm'}", tmp_path / "run"
    seeds = "reference.seeds=[0,1,2]"
    first = run("runners.control", *CONTROL_TINY, models, seeds, f"hydra.run.dir={run_dir}")
    assert first.returncode == 0, first.stderr[-2000:]
    table = pd.read_csv(run_dir / "summary.csv")
    table.iloc[:1].to_csv(run_dir / "summary.csv", index=False)  # killed after seed 0
    again = run("runners.control", *CONTROL_TINY, models, seeds, f"hydra.run.dir={run_dir}")
    assert again.returncode == 0, again.stderr[-2000:]
    assert "1 references finished before" in output(again)
    rerun = pd.read_csv(run_dir / "summary.csv")
    assert rerun["seed"].tolist() == [0, 1, 2]
    pd.testing.assert_frame_equal(
        rerun.drop(columns=["latency_median_ms", "latency_p99_ms"]),
        table.drop(columns=["latency_median_ms", "latency_p99_ms"]),
    )
    from mcpilco.tracking import read_run_log

    assert read_run_log(run_dir).trials["trial"].tolist() == [0, 1, 2]  # each logged once
    from analysis.control_report import run_dirs, tracking_table

    assert tracking_table(run_dirs([run_dir]))["seeds"].tolist() == [3]  # not "0/4"


def test_generating_the_data_sets_twice_keeps_one_row_each(tmp_path: Path) -> None:
    arguments = [
        *CGPDM_TINY,
        "mode=generate",
        "data.ranges=[30]",
        f"hydra.run.dir={tmp_path / 'g'}",
    ]
    assert run("runners.cgpdm", *arguments).returncode == 0
    stamp = (tmp_path / "g" / "datasets" / "R30.npz").stat().st_mtime_ns
    again = run("runners.cgpdm", *arguments)
    assert again.returncode == 0, again.stderr[-2000:]
    assert pd.read_csv(tmp_path / "g" / "summary.csv")["range_deg"].tolist() == [30.0]
    assert (tmp_path / "g" / "datasets" / "R30.npz").stat().st_mtime_ns == stamp  # not redone
    replay = run("runners.replay", str(tmp_path / "g"))
    assert replay.returncode == 0 and "replayed sequences [0, 1, 2, 3, 4]" in replay.stderr


@pytest.mark.slow  # CI time (make test-slow runs it)
def test_a_damaged_control_model_is_refused_in_one_line(tmp_path: Path) -> None:
    """A model.json holding [] and a gp.pt that does not fit the model (item 7)."""
    import torch

    models = tmp_path / "m"
    arguments = [*CONTROL_TINY, "reference.seeds=[0]", f"model_dir={models}"]
    assert run("runners.control", *arguments, f"hydra.run.dir={tmp_path / 'a'}").returncode == 0
    record = (models / "model.json").read_text()
    (models / "model.json").write_text("[]")
    listed = run("runners.control", *arguments, f"hydra.run.dir={tmp_path / 'b'}")
    assert listed.returncode == 2 and len(errors(listed)) == 1
    assert "model.json holds a list" in errors(listed)[0] and "Traceback" not in output(listed)
    (models / "model.json").write_text(record)
    torch.save({"gp.something_else": torch.zeros(3)}, models / "gp.pt")
    other = run("runners.control", *arguments, f"hydra.run.dir={tmp_path / 'c'}")
    assert other.returncode == 1 and len(errors(other)) == 1
    assert "gp.pt does not fit the model" in errors(other)[0] and "Traceback" not in output(other)


# ------------------------------------------------- 4. a kill never breaks the data cache
def test_a_half_written_data_set_is_simulated_again(tmp_path: Path, cgpdm_run: Path) -> None:
    cache = tmp_path / "data"
    shutil.copytree(cgpdm_run / "data", cache)
    (dataset,) = cache.glob("*.npz")
    dataset.with_suffix(".json").unlink()  # the order of old: .npz in place, .json not yet
    result = run(
        "runners.cgpdm", *CGPDM_TINY, f"data.dir={cache}", f"hydra.run.dir={tmp_path / 'r'}"
    )
    assert result.returncode == 0, result.stderr[-2000:]
    assert "cannot be read" in output(result) and "simulating it again" in output(result)
    assert dataset.with_suffix(".json").is_file()
    from mcpilco.cloth import ClothDataset

    ClothDataset.load(dataset)  # whole again


# ------------------------- 5. resuming another runner's directory touches nothing there
@pytest.mark.parametrize("runner", ["cgpdm", pytest.param("control", marks=pytest.mark.slow)])
def test_train_resume_of_another_kind_of_run_is_refused_untouched(
    tmp_path: Path, cgpdm_run: Path, runner: str
) -> None:
    if runner == "cgpdm":
        target = tmp_path / "run"
        shutil.copytree(cgpdm_run / "run", target)
    else:
        target = tmp_path / "control"
        made = run("runners.control", *CONTROL_TINY, "reference.seeds=[0]",
                   f"model_dir={tmp_path / 'm'}", f"hydra.run.dir={target}")  # fmt: skip
        assert made.returncode == 0, made.stderr[-2000:]
    before = listing(target)
    resumed = run("runners.train", f"resume={target}")
    assert resumed.returncode == 2 and len(errors(resumed)) == 1
    assert f"holds a {runner} run, not a train run" in errors(resumed)[0]
    assert "Traceback" not in output(resumed)
    assert listing(target) == before  # no failed.txt, no train.log
    if runner == "cgpdm":
        assert (
            run("analysis.cgpdm_report", str(target), "--out", str(tmp_path / "o")).returncode == 0
        )


# --------------------------------------------- 6. the log chunk before the summary row
def test_cgpdm_closes_each_sequence_log_chunk_before_its_row(
    tmp_path: Path, cgpdm_run: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import numpy as np

    import runners.cgpdm_job as cgpdm
    from mcpilco.run_contract import CGPDM, KINDS, RunContract
    from mcpilco.run_storage import RunDirectory

    storage = RunDirectory(tmp_path)
    seen: list[tuple[int, list[int]]] = []

    class Spy:
        def run_started(self, metadata: object, resumed_after: int) -> None:
            pass

        def rollout(self, *args: object, **kwargs: object) -> None:
            pass

        def trial_finished(self, trial: int, row: object) -> None:
            seen.append((trial, storage.finished_units("sequence")))

        def close(self) -> None:
            pass

    monkeypatch.setattr(cgpdm, "tracking_observers", lambda cfg, path: [Spy()])
    cfg = OmegaConf.load(cgpdm_run / "run" / "config.yaml")
    with np.load(cgpdm_run / "run" / "predictions.npz") as arrays:
        true, predicted = arrays["true"], arrays["predicted"]
        latent, controls = arrays["latent"], arrays["controls"]
    from mcpilco.cloth import ClothDataset
    from mcpilco.latent.study import score

    test = ClothDataset(true, controls, np.array([3, 4]), {})
    results = cgpdm.TestResults(
        test, latent, predicted, score(test, predicted), 1.0, 0.1, 0.0, [0, 1, 2]
    )
    cgpdm.log_test_sequences(cfg, RunContract(storage, CGPDM, KINDS), results, [])
    assert seen == [(0, []), (1, [3])]  # each row written after its chunk was closed
    assert storage.finished_units("sequence") == [3, 4]


def test_replay_fails_when_no_whole_unit_is_logged_and_warns_of_missing_ones(
    tmp_path: Path, cgpdm_run: Path
) -> None:
    run_dir = tmp_path / "run"
    shutil.copytree(cgpdm_run / "run", run_dir)
    log = run_dir / "rollouts.mcap"
    data = log.read_bytes()
    log.write_bytes(data[: len(data) // 2])  # the second sequence's chunk is lost
    partial = run("runners.replay", str(run_dir))
    assert partial.returncode == 0
    assert "[1] are finished (summary.csv) but not whole in the log" in partial.stderr
    log.write_bytes(data[:200])  # nothing whole is left
    empty = run("runners.replay", str(run_dir))
    assert empty.returncode == 2 and "holds no whole" in empty.stderr
    (tmp_path / "t").mkdir()
    write_log(tmp_path / "t", 2)
    (tmp_path / "t" / "rollouts.mcap").write_bytes(
        (tmp_path / "t" / "rollouts.mcap").read_bytes()[:200]
    )
    assert run("runners.replay", str(tmp_path / "t")).returncode == 2


# ----------------------------------------------------- 8. absurd sizes refused at once
@pytest.mark.parametrize(
    ("module", "overrides", "key"),
    [
        ("runners.train", ["optimizer.num_particles=1000000000"], "optimizer.num_particles"),
        # slow: CI time (one case per runner stays in make test)
        pytest.param(
            "runners.train", ["policy.num_basis=1000000000"], "policy.num_basis", marks=SLOW
        ),
        pytest.param(
            "runners.train", ["system.trial_duration=1000000000"], "trial duration", marks=SLOW
        ),
        ("runners.control", ["data.duration=1000000000"], "data.duration"),
        pytest.param(
            "runners.control", ["reference.duration=1000000000"], "reference.duration", marks=SLOW
        ),
        ("runners.cgpdm", ["data.num_sequences=1000000000"], "data.num_sequences"),
        pytest.param(
            "runners.cgpdm",
            ["cloth.timestep=1e-10", "cloth.edge_timeconst=0.002"],
            "cloth.timestep",
            marks=SLOW,
        ),
    ],
)
def test_absurd_sizes_are_refused_before_any_allocation(
    tmp_path: Path, module: str, overrides: list[str], key: str
) -> None:
    start = time.perf_counter()
    where = {"runners.cgpdm": [f"data.dir={tmp_path / 'd'}"],
             "runners.control": [f"model_dir={tmp_path / 'd'}"]}.get(module, [])  # fmt: skip
    result = run(module, *overrides, *where, f"hydra.run.dir={tmp_path / 'r'}")
    assert result.returncode == 2, output(result)[-2000:]
    assert len(errors(result)) == 1 and key in errors(result)[0], errors(result)
    assert "Traceback" not in output(result) and time.perf_counter() - start < 60
    assert not (tmp_path / "r" / "summary.csv").exists() and not (tmp_path / "d").exists()


# ------------------------------------------------------------------------ 9. smaller
def test_sigterm_is_handled_like_ctrl_c_and_the_rerun_completes(tmp_path: Path) -> None:
    """SIGTERM (a scheduler's preemption) leaves failed.txt and the finished seeds; the
    message names the unit; the rerun does the rest."""
    run_dir, seeds = tmp_path / "run", "reference.seeds=[0,1,2,3,4,5,6,7,8,9]"
    command = [
        sys.executable, "-m", "runners.control", *CONTROL_TINY, seeds, "reference.duration=1.5",
        f"model_dir={tmp_path / 'm'}", f"hydra.run.dir={run_dir}",
    ]  # fmt: skip
    process = subprocess.Popen(
        command, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )
    deadline = time.time() + 300
    while not (run_dir / "summary.csv").exists() and time.time() < deadline:
        time.sleep(0.05)
    process.send_signal(signal.SIGTERM)
    text, _ = process.communicate(timeout=120)
    assert process.returncode == 143, text[-2000:]
    assert "terminated (SIGTERM); the finished references are kept" in text
    assert "Traceback" not in text and (run_dir / "failed.txt").is_file()
    finished = pd.read_csv(run_dir / "summary.csv")["seed"].tolist()
    assert finished == list(range(len(finished))) and len(finished) < 10
    again = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert again.returncode == 0, again.stderr[-2000:]
    assert pd.read_csv(run_dir / "summary.csv")["seed"].tolist() == list(range(10))
    assert not (run_dir / "failed.txt").exists()


def test_a_second_ctrl_c_exits_at_once_without_a_traceback(tmp_path: Path) -> None:
    command = [sys.executable, "-m", "runners.train", "threads=1", "compile=false",
               f"hydra.run.dir={tmp_path / 'run'}"]  # fmt: skip
    process = subprocess.Popen(
        command, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )
    deadline = time.time() + 300
    while not (tmp_path / "run" / "summary.csv").exists() and time.time() < deadline:
        time.sleep(0.05)
    process.send_signal(signal.SIGINT)
    process.send_signal(signal.SIGINT)
    text, _ = process.communicate(timeout=120)
    assert process.returncode in (130, 2), text[-2000:]
    assert "Traceback" not in text
    assert pd.read_csv(tmp_path / "run" / "summary.csv")["trial"].tolist() == [0]


@pytest.mark.parametrize(
    "content",
    [
        pytest.param("", id="empty"),
        pytest.param("not,a\n\x00\x01,table,at,all\n", id="corrupt", marks=pytest.mark.slow),
    ],
)
def test_an_empty_or_corrupt_summary_is_named_in_one_line(
    tmp_path: Path, train_run: Path, content: str
) -> None:
    run_dir = tmp_path / "run"
    shutil.copytree(train_run, run_dir, ignore=shutil.ignore_patterns(".mcpilco.lock"))
    (run_dir / "summary.csv").write_text(content)
    for result in (
        run("analysis.evaluate", str(run_dir)),
        run("runners.train", f"resume={run_dir}", "num_trials=2"),
    ):
        assert result.returncode in (1, 2), output(result)[-2000:]
        assert "Traceback" not in output(result) and "summary.csv" in output(result)
    summary = run("analysis.summary", str(tmp_path))
    assert "Traceback" not in output(summary) and "unreadable" in output(summary)


def test_analysis_of_another_kind_of_run_is_one_line(tmp_path: Path, cgpdm_run: Path) -> None:
    evaluated = run("analysis.evaluate", str(cgpdm_run / "run"))
    assert evaluated.returncode != 0 and "holds a cgpdm run, not a training run" in evaluated.stderr
    assert "Traceback" not in output(evaluated)
    summary = run("analysis.summary", str(cgpdm_run / "run"))
    assert summary.returncode != 0 and "read by analysis.cgpdm_report" in output(summary)
    assert "Traceback" not in output(summary)


def test_one_bad_predictions_file_does_not_stop_the_cgpdm_report(
    tmp_path: Path, cgpdm_run: Path
) -> None:
    for name in ("good", "bad"):
        shutil.copytree(cgpdm_run / "run", tmp_path / "sweep" / name)
    (tmp_path / "sweep" / "bad" / "predictions.npz").write_bytes(b"PK\x03\x04 not a zip")
    report = run("analysis.cgpdm_report", str(tmp_path / "sweep"), "--out", str(tmp_path / "o"))
    assert report.returncode == 0, report.stderr[-2000:]
    assert "bad: unreadable" in output(report)
    assert len(pd.read_csv(tmp_path / "o" / "models.csv")) == 1


@pytest.mark.slow  # CI time (make test-slow runs it)
def test_two_identical_sweeps_on_one_directory_both_succeed(tmp_path: Path) -> None:
    command = [
        sys.executable, "-m", "runners.cgpdm", "--multirun", *CGPDM_TINY, "seed=0,1",
        f"data.dir={tmp_path / 'data'}", f"hydra.sweep.dir={tmp_path / 'sweep'}",
    ]  # fmt: skip
    subprocess.run(
        [
            *command[:3],
            *CGPDM_TINY,
            "mode=train",
            f"data.dir={tmp_path / 'data'}",
            f"hydra.run.dir={tmp_path / 'warm'}",
        ],
        cwd=tmp_path,
        timeout=600,
        check=True,
        capture_output=True,
    )  # fmt: skip  (the data set cached first)
    processes = [
        subprocess.Popen(
            command, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
        )
        for _ in range(2)
    ]
    texts = [p.communicate(timeout=600)[0] for p in processes]
    assert [p.returncode for p in processes] == [0, 0], texts
    summaries = sorted((tmp_path / "sweep").rglob("summary.csv"))
    assert len(summaries) == 2
    for summary in summaries:
        assert pd.read_csv(summary)["sequence"].tolist() == [3, 4]  # each model once


def test_the_target_rule_sits_below_the_library_and_knows_no_class_by_name() -> None:
    """safe_config imports nothing of the library (no circle with build.py); the extension
    points make themselves known by deriving from ExtensionPoint."""
    probe = (
        "import sys, mcpilco.safe_config\n"
        "print(sorted(m for m in sys.modules if m.startswith('mcpilco')))\n"
        "import mcpilco.systems, mcpilco.kernels, mcpilco.costs\n"
        "from mcpilco.extension import extension_points\n"
        "print(sorted(c.__name__ for c in extension_points()))\n"
    )
    result = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    first, second = result.stdout.splitlines()
    assert first == str(["mcpilco", "mcpilco.errors", "mcpilco.extension", "mcpilco.safe_config"])
    assert {"MechanicalSystem", "Kernel", "Cost"} <= set(json.loads(second.replace("'", '"')))
