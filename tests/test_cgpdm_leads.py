"""analysis.cgpdm_leads and cgpdm_report --earlier on per-model tables with known errors."""

from __future__ import annotations

import itertools
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from analysis.cgpdm_leads import combine, compare


def models_table(
    variant: str, errors: dict[int, list[float]], units: str = "unitless"
) -> pd.DataFrame:
    """A models.csv of one variant: ``errors[num_train][draw]``."""
    rows = [
        {"range_deg": 30, "variant": variant, "num_train": n, "draw": d, "units": units,
         "error": e, "still_error": 0.6, "rigid_error": 0.3, "fit_seconds": 1.0 * n,
         "predict_seconds": 0.01, "test_sequences": 10, "left_region": 0.0, "run": f"/r/{d}"}
        for n, values in errors.items() for d, e in enumerate(values)
    ]  # fmt: skip
    return pd.DataFrame(rows)


BASE = {5: [0.30, 0.40, 0.50, 0.20, 0.35], 10: [0.25, 0.30, 0.20]}
# the candidate: 0.05 better on every draw of 5 sequences, 0.10 worse on draw 0 of 10
CANDIDATE = {5: [e - 0.05 for e in BASE[5]], 10: [0.35, 0.30 - 1e-3, 0.20 - 2e-3]}


def test_compare_pairs_draws_and_averages_cells() -> None:
    models = combine([models_table("base", BASE), models_table("cand", CANDIDATE)], ["a", "b"])
    row = compare(models, "base", ["cand"]).iloc[0]
    differences = np.array([-0.05] * 5 + [0.10, -1e-3, -2e-3])
    assert row.pairs == 8 and row.candidate_better == 7 and row.sizes == "5 10"
    assert row.mean_difference == pytest.approx(differences.mean())
    # the exact two-sided signed-rank test by enumerating the 2^8 sign flips of the ranks
    # of |d| (1, 2, five tied at 5, 8): the candidate's positive rank sum is 8 of 36
    ranks = np.array([5.0] * 5 + [8.0, 1.0, 2.0])
    flips = np.array(list(itertools.product([0, 1], repeat=8)), dtype=bool)
    positive = (flips * ranks).sum(axis=1)
    exact = np.mean(np.abs(positive - 18.0) >= abs(8.0 - 18.0))
    assert exact == pytest.approx(50 / 256) and row.wilcoxon_p == pytest.approx(exact)
    assert row.baseline_mean_of_cells == pytest.approx((np.mean(BASE[5]) + 0.25) / 2)
    assert row.candidate_mean_of_cells == pytest.approx(
        (np.mean(CANDIDATE[5]) + np.mean(CANDIDATE[10])) / 2
    )


def test_five_wins_of_five_give_the_exact_p_value() -> None:
    models = combine(
        [models_table("base", {5: BASE[5]}), models_table("cand", {5: CANDIDATE[5]})], ["a", "b"]
    )
    assert compare(models, "base", ["cand"]).iloc[0].wilcoxon_p == pytest.approx(2 / 32)


def test_a_model_given_twice_is_refused_naming_it() -> None:
    with pytest.raises(ValueError, match=r"variant=base, num_train=10, draw=0 .*\(a and b\)"):
        combine([models_table("base", BASE), models_table("base", {10: [0.0, 0.1]})], ["a", "b"])
    with pytest.raises(ValueError, match="no model of the variant 'other'"):
        compare(models_table("base", BASE), "base", ["other"])


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", *args], capture_output=True, text=True, timeout=300
    )


def test_command_writes_the_comparison_and_refuses_bad_input(tmp_path: Path) -> None:
    models_table("base", BASE).to_csv(tmp_path / "a.csv", index=False)
    models_table("cand", CANDIDATE).to_csv(tmp_path / "b.csv", index=False)
    out = tmp_path / "leads.csv"
    result = run("analysis.cgpdm_leads", str(tmp_path / "a.csv"), str(tmp_path / "b.csv"),
                 "--group", "base:cand", "--out", str(out))  # fmt: skip
    assert result.returncode == 0, result.stderr[-2000:]
    assert pd.read_csv(out).candidate_better.tolist() == [7]
    assert "| base | cand | 8 (5 10) | 7 |" in result.stderr
    result = run("analysis.cgpdm_leads", str(tmp_path / "a.csv"), str(tmp_path / "a.csv"),
                 "--group", "base:cand")  # fmt: skip
    assert result.returncode != 0 and "given twice" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    result = run("analysis.cgpdm_leads", str(tmp_path / "a.csv"), "--group", "base")
    assert result.returncode != 0 and "BASELINE:CANDIDATE" in result.stderr


def test_report_adds_earlier_models_and_refuses_one_held_twice(tmp_path: Path) -> None:
    from tests.test_cgpdm_report import write_runs

    write_runs(tmp_path / "runs")  # high and low, 5 and 10 sequences, draws 0-4
    earlier = models_table("high", {5: [0.9, 0.9, 0.9, 0.9, 0.9, 0.1]}, units="m")
    earlier[earlier.draw == 5].to_csv(tmp_path / "earlier.csv", index=False)
    result = run("analysis.cgpdm_report", str(tmp_path / "runs"), "--out", str(tmp_path / "out"),
                 "--earlier", str(tmp_path / "earlier.csv"))  # fmt: skip
    assert result.returncode == 0, result.stderr[-2000:]
    models = pd.read_csv(tmp_path / "out" / "models.csv")
    assert len(models) == 21 and models[models.draw == 5].error.tolist() == [0.1]
    assert "| 30 | high | 5 | 6 |" in (tmp_path / "out" / "errors.md").read_text()
    earlier.to_csv(tmp_path / "earlier.csv", index=False)  # draws 0-4 too: held twice
    result = run("analysis.cgpdm_report", str(tmp_path / "runs"), "--out", str(tmp_path / "o2"),
                 "--earlier", str(tmp_path / "earlier.csv"))  # fmt: skip
    assert result.returncode != 0 and "given twice" in result.stderr.strip().splitlines()[-1]
