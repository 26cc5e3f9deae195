"""Replaying stored cost traces through a changed monitoring schedule (analysis.schedule_replay),
on traces whose recorded decisions are known in closed form."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from analysis.schedule_replay import load, parse_settings
from analysis.wasted_steps import trial_rows

RECORDED = {
    "dropout": 0.25,
    "dropout_step": 0.125,
    "learning_rate": 0.01,
    "learning_rate_min": 0.0025,
    "ema": 0.99,
    "threshold": 0.08,
    "threshold_min": 0.01,
    "window": 200,
    "factor": 0.5,
}


def write_run(
    root: Path, costs: list[float], reductions: list[int], horizon: int | None = 60
) -> Path:
    """A run directory with one trace: α_lr halves after each step in ``reductions``."""
    (root / "optimization").mkdir(parents=True)
    (root / "config.yaml").write_text(yaml.safe_dump({"optimizer": {"schedule": RECORDED}}))
    steps = np.arange(len(costs))
    halvings = np.searchsorted(np.asarray(reductions), steps, side="right")
    trace = pd.DataFrame(
        {
            "step": steps,
            "cost": costs,
            "dropout": 0.25 - 0.125 * halvings,
            "learning_rate": 0.01 * 0.5**halvings,
            "signal": 0.0,
        }
    )
    if horizon is not None:  # runs from before the horizon curriculum have no such column
        trace["horizon"] = horizon
    trace.to_csv(root / "optimization" / "trial_01.csv", index=False)
    return root


def flat_run(root: Path) -> Path:
    # A flat cost: s = 0 < σ_s from the first change on, so the thesis schedule reduces
    # after steps 200, 400 and 600 (each n_s = 200 steps below σ_s) and stops at the third.
    return write_run(root, [5.0] * 601, [200, 400, 600])


def test_shorter_window_reduces_first_at_its_own_length(tmp_path: Path) -> None:
    row = load([flat_run(tmp_path)], {"window": 100}).iloc[0]
    assert (row["changed_schedule"], row["diverges_at"]) == ("reduces", 100)


def test_a_change_that_decides_nothing_differently_is_the_same_run(tmp_path: Path) -> None:
    # With a flat cost the variance of the changes is 0, so the ratio is 0 with or without
    # the bias correction: every decision is the recorded one.
    row = load([flat_run(tmp_path)], {"bias_correction": True}).iloc[0]
    assert row["changed_schedule"] == "same"
    assert pd.isna(row["diverges_at"])


def test_longer_window_holds_with_its_earliest_next_reduction(tmp_path: Path) -> None:
    # Below σ_s since step 1: at step 200 a schedule with n_s = 300 has counted 200 steps,
    # so it can reduce no earlier than step 300.
    row = load([flat_run(tmp_path)], {"window": 300}).iloc[0]
    assert (row["changed_schedule"], row["diverges_at"], row["earliest_next"]) == (
        "holds",
        200,
        300,
    )


def test_a_trace_without_a_horizon_column_replays(tmp_path: Path) -> None:
    run = write_run(tmp_path, [5.0] * 601, [200, 400, 600], horizon=None)
    assert load([run], {"window": 100}).iloc[0]["changed_schedule"] == "reduces"


def test_a_trace_that_runs_on_after_the_recorded_stop_is_not_reproduced(tmp_path: Path) -> None:
    # The thesis schedule stops at its third reduction (step 600); 700 steps cannot be its.
    run = write_run(tmp_path, [5.0] * 701, [200, 400, 600])
    assert load([run], {"window": 100}).iloc[0]["changed_schedule"] == "not reproduced"


def test_a_run_without_a_monitoring_schedule_fails_naming_it(tmp_path: Path) -> None:
    run = flat_run(tmp_path)
    (run / "config.yaml").write_text(yaml.safe_dump({"optimizer": {"max_steps": 10}}))
    with pytest.raises(SystemExit, match="config.yaml: no optimizer.schedule"):
        load([run], {})


def test_a_file_that_is_not_a_trace_fails_naming_it(tmp_path: Path) -> None:
    run = flat_run(tmp_path)
    (run / "optimization" / "trial_01.csv").write_text("step,signal\n0,0.0\n")
    with pytest.raises(SystemExit, match="trial_01.csv: no column"):
        load([run], {})


def test_a_trace_the_recorded_schedule_does_not_reproduce_is_flagged(tmp_path: Path) -> None:
    write_run(tmp_path / "wrong", [5.0] * 601, [150, 400, 600])
    staged = write_run(tmp_path / "staged", [5.0] * 601, [200, 400, 600])
    trace = pd.read_csv(staged / "optimization" / "trial_01.csv")
    trace.loc[300:, "horizon"] = 90
    trace.to_csv(staged / "optimization" / "trial_01.csv", index=False)
    table = load([tmp_path], {"window": 100})
    assert table["changed_schedule"].tolist() == ["not reproduced", "not reproduced"]


def test_the_recorded_reductions_agree_with_wasted_steps(tmp_path: Path) -> None:
    run = flat_run(tmp_path)
    assert load([run], {}).iloc[0]["recorded_reductions"] == "200 400 600"
    assert trial_rows(run, 0.01)[0]["reductions_at"] == "200 400 600"


@pytest.mark.parametrize("pair", ["window", "=3", "windw=100", "signal=0.5"])
def test_bad_settings_name_the_pair(pair: str) -> None:
    with pytest.raises(SystemExit, match=pair.split("=")[0] or "KEY=VALUE"):
        parse_settings([pair])


def test_settings_are_read_as_yaml() -> None:
    assert parse_settings(["window=100", "bias_correction=true"]) == {
        "window": 100,
        "bias_correction": True,
    }
