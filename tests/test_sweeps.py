"""Seed × kernel sweeps through Hydra launchers: parallel local jobs, submitit, resume."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from analysis.swing_up import pole_swings
from tests.test_runner import ONE_TINY_TRIAL, run_module

ROOT = Path(__file__).resolve().parent.parent
TINY_SWEEP = ["--multirun", *ONE_TINY_TRIAL, "seed=0,1", "kernel=se,sp"]


def sweep(*overrides: str) -> subprocess.CompletedProcess[str]:
    return run_module("runners.train", *overrides, timeout=300)


def job_summaries(sweep_dir: Path) -> dict[str, pd.DataFrame]:
    return {p.parent.name: pd.read_csv(p) for p in sorted(sweep_dir.glob("*/summary.csv"))}


def test_local_parallel_sweep_runs_every_job_and_skips_them_when_rerun(tmp_path: Path) -> None:
    command = [*TINY_SWEEP, "hydra/launcher=local_parallel", f"hydra.sweep.dir={tmp_path}"]
    first = sweep(*command)
    assert first.returncode == 0, first.stderr[-3000:]
    summaries = job_summaries(tmp_path)
    assert sorted(summaries) == [
        f"kernel={k},optimizer.max_steps=3,optimizer.max_steps_first_trial=3,"
        f"optimizer.num_particles=8,policy.num_basis=10,seed={s},system.trial_duration=0.5"
        for k in ("se", "sp")
        for s in (0, 1)
    ]
    assert all(table["trial"].tolist() == [0, 1] for table in summaries.values())
    stamps = {name: (tmp_path / name / "summary.csv").stat().st_mtime_ns for name in summaries}

    again = sweep(*command)
    assert again.returncode == 0, again.stderr[-3000:]
    for name, table in job_summaries(tmp_path).items():  # nothing recomputed
        pd.testing.assert_frame_equal(table, summaries[name])
        assert (tmp_path / name / "summary.csv").stat().st_mtime_ns == stamps[name]

    check_report(tmp_path, summaries)

    fresh = sweep(*command[:-1], "seed=0", "kernel=se", "overwrite=true", command[-1])
    assert fresh.returncode == 0, fresh.stderr[-3000:]
    redone = [
        n for n in summaries if (tmp_path / n / "summary.csv").stat().st_mtime_ns != stamps[n]
    ]
    assert len(redone) == 1 and "kernel=se" in redone[0] and "seed=0" in redone[0]


def test_failed_job_is_recorded_and_the_sweep_goes_on(tmp_path: Path) -> None:
    result = sweep(
        *TINY_SWEEP[:-2],
        "seed=0",
        "system.dt=-0.05,0.05",
        f"hydra.sweep.dir={tmp_path}",
    )
    assert result.returncode != 0  # the sweep reports the failure at its end
    failed = sorted(p.parent.name for p in tmp_path.glob("*/failed.txt"))
    finished = sorted(p.parent.name for p in tmp_path.glob("*/summary.csv"))
    assert len(failed) == 1 and "system.dt=-0.05" in failed[0]
    assert "system.dt must be positive" in (tmp_path / failed[0] / "failed.txt").read_text()
    assert len(finished) == 1 and "system.dt=0.05" in finished[0]


@pytest.mark.slow  # CI time (make test-slow runs it)
def test_submitit_local_sweep(tmp_path: Path) -> None:
    pytest.importorskip("hydra_plugins.hydra_submitit_launcher")
    result = sweep(
        *TINY_SWEEP,
        "hydra/launcher=submitit_local",
        "hydra.launcher.timeout_min=5",
        f"hydra.sweep.dir={tmp_path}",
    )
    assert result.returncode == 0, result.stderr[-3000:]
    summaries = job_summaries(tmp_path)
    assert len(summaries) == 4
    assert all(table["trial"].tolist() == [0, 1] for table in summaries.values())


def check_report(sweep_dir: Path, summaries: dict[str, pd.DataFrame]) -> None:
    """analysis.report on the sweep: its success counts equal the per-run summaries."""
    from analysis.report import write_report

    write_report([sweep_dir], sweep_dir / "report", "test")
    rates = pd.read_csv(sweep_dir / "report" / "success_rates.csv")
    tiny = " [not the thesis's budget: M 8, N_opt T1 3, N_opt 3, n_b 10, T (s) 0.5]"
    assert set(rates["configuration"]) == {  # tiny runs, never read as the thesis's setting
        "S.I., SE, dropout, l=(3,1)" + tiny,
        "S.I., PI+SE, dropout, l=(3,1)" + tiny,
    }
    for row in rates.itertuples():
        kernel = "kernel=sp" if "PI+SE" in row.configuration else "kernel=se"
        runs = [t for name, t in summaries.items() if name.startswith(kernel)]
        expected = sum(bool(t.loc[t["trial"] == row.trial, "success"].iloc[0]) for t in runs)
        assert (row.runs, row.successes) == (len(runs), expected)
    solved = pd.read_csv(sweep_dir / "report" / "solved_by_trial.csv")  # one trial each
    pd.testing.assert_frame_equal(
        solved[["configuration", "trial", "observed", "solved"]],
        rates[["configuration", "trial", "runs", "successes"]].set_axis(
            ["configuration", "trial", "observed", "solved"], axis=1
        ),
    )
    assert "two-sided sign test" in (sweep_dir / "report" / "paired.md").read_text()
    for name in ("index.md", "success_rates.md", "precision.md", "cumulative_cost.png"):
        assert (sweep_dir / "report" / name).stat().st_size > 0
    # one-step prediction errors of trial 1's model on trial 1's 10 steps, both GP outputs
    errors = pd.read_csv(sweep_dir / "report" / "prediction_errors.csv")
    assert sorted(errors["output"]) == ["d_x1", "d_x1", "d_x3", "d_x3"]
    assert (errors["count"] == 2 * 10).all() and (errors["min"] >= 0).all()
    assert (sweep_dir / "report" / "prediction_errors.png").stat().st_size > 0


def test_wilson_interval_matches_the_textbook_value() -> None:
    from analysis.report import wilson_interval

    low, high = wilson_interval(8, 10)  # p = 0.8, n = 10, 95 %: [0.490, 0.943]
    assert (round(low, 3), round(high, 3)) == (0.49, 0.943)
    assert wilson_interval(0, 4)[0] == 0.0
    assert wilson_interval(4, 4)[1] == pytest.approx(1.0)


def test_configuration_labels_name_the_thesis_rows() -> None:
    from hydra import compose, initialize_config_dir
    from omegaconf import OmegaConf

    from analysis.thesis import SUCCESS_RATES, configuration_label, thesis_label

    cases = {
        (): "S.I., SE, dropout, l=(3,1)",
        ("kernel=sp",): "S.I., PI+SE, dropout, l=(3,1)",
        ("kernel=se_p2", "model=full_state"): "F.S., SE+P(2), dropout, l=(3,1)",
        (
            "optimizer=mcpilco_no_dropout",
            "cost=cartpole_swingup_selective",
        ): "S.I., SE, no dropout, l=(0.75,0.25)",
        ("+experiment=cartpole_df",): "DF m_q=2 m_u=1, SE, dropout, l=(3,1)",
        ("+experiment=cartpole_pms",): "PMS S.I., SE, dropout, l=(3,1)",
        ("protocol=quick", "kernel=sp"): "S.I., PI+SE, dropout, l=(3,1) [quick]",
        ("+experiment=furuta_pms",): "FurutaPendulum: PMS S.I., SE, dropout, l=()",
        ("+experiment=furuta_pms_curriculum", "kernel=sp"): (
            "FurutaPendulum: PMS S.I., PI+SE, dropout, l=(), horizon curriculum"
        ),
        ("+experiment=furuta_df",): "FurutaPendulum: DF m_q=2 m_u=1, SE, dropout, l=()",
    }
    for overrides, label in cases.items():
        with initialize_config_dir(version_base="1.3", config_dir=str(ROOT / "conf")):
            cfg = compose("train", overrides=list(overrides))
        config = OmegaConf.to_container(cfg, resolve=True)
        assert configuration_label(config) == label  # type: ignore[arg-type]
    assert "S.I., SE, dropout, l=(3,1)" in SUCCESS_RATES
    assert thesis_label("S.I., PI+SE, dropout, l=(3,1) [quick]") in SUCCESS_RATES


def test_pole_swings_counts_velocity_reversals_before_upright() -> None:
    # pumped swing-up: right, left, right, then over the top (2 reversals before upright);
    # the first sample is rest noise below the dead band and has no sign
    velocity = np.array([-0.01, 2.0, 1.0, -1.5, -2.0, 1.0, 3.0, 4.0, 0.5, -0.5])
    angle = np.array([0.0, 0.3, 0.6, 0.4, -0.5, -0.3, 1.0, 2.5, 3.1, 3.2])
    assert pole_swings(angle, velocity) == 2  # upright first at index 8 (|3.1 − π| < 20°)
    assert pole_swings(angle - 2 * np.pi, velocity) == 2  # angles are not wrapped in logs
    assert pole_swings(angle, -velocity) == 2
    assert pole_swings(np.zeros(10), velocity) is None  # never upright
    assert pole_swings(angle, np.full(10, 0.01)) == 0  # only noise: no swing
