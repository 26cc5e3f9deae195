"""analysis.cgpdm_report on synthetic run directories with known errors."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from analysis.cgpdm_report import cells, load_models, paired

ROOT = Path(__file__).resolve().parent.parent


def write_runs(root: Path) -> dict[tuple[str, int], list[float]]:
    """Runs of 2 variants x 2 sizes x 5 draws, 3 test sequences each; returns each cell's
    per-draw model errors (the mean over its test sequences)."""
    expected: dict[tuple[str, int], list[float]] = {}
    for variant, offset in (("high", 0.0), ("low", 0.01)):
        for num_train in (5, 10):
            for draw in range(5):
                errors = 0.02 + offset + 0.001 * draw + np.array([0.0, 0.003, 0.006]) / num_train
                run = root / f"{variant}_{num_train}_{draw}"
                run.mkdir(parents=True)
                pd.DataFrame({
                    "trial": range(3), "sequence": [40, 41, 42], "range_deg": 30.0,
                    "num_train": num_train, "draw": draw, "variant": variant, "error_m": errors,
                    "still_error_m": 0.05, "rigid_error_m": 0.009, "eval_cost": errors,
                    "fit_seconds": 10.0 * num_train, "predict_seconds": 0.002, "final_loss": -1.0,
                }).to_csv(run / "summary.csv", index=False)  # fmt: skip
                expected.setdefault((variant, num_train), []).append(float(errors.mean()))
    failed = root / "broken"
    failed.mkdir()
    (failed / "failed.txt").write_text("Traceback ...")
    return expected


def test_cells_are_means_with_student_t_intervals_over_draws(tmp_path: Path) -> None:
    expected = write_runs(tmp_path)
    models, left_out = load_models([tmp_path])
    assert left_out == [tmp_path / "broken"] and len(models) == 20
    table = cells(models).set_index(["variant", "num_train"])
    for key, values in expected.items():
        row = table.loc[key]
        assert row.draws == 5 and row.error_mean == pytest.approx(np.mean(values))
        # t_{0.975, 4} = 2.776; the draws differ by 1 mm steps: std = 1.5811e-3
        assert row.error_ci95 == pytest.approx(2.776445 * np.std(values, ddof=1) / np.sqrt(5))
        assert row.fit_seconds == 10.0 * key[1] and row.predict_ms == pytest.approx(2.0)
    comparison = paired(models).set_index("num_train")
    assert comparison.loc[5, "high_better"] == 5 and comparison.loc[10, "draws"] == 5
    assert comparison.loc[5, "wilcoxon_p"] == pytest.approx(0.0625)  # 5 of 5, exact test


def test_report_command_writes_the_table_and_figure(tmp_path: Path) -> None:
    write_runs(tmp_path / "runs")
    result = subprocess.run(
        [sys.executable, "-m", "analysis.cgpdm_report", str(tmp_path / "runs"),
         "--out", str(tmp_path / "out")],
        cwd=Path.cwd(), capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr[-2000:]
    text = (tmp_path / "out" / "errors.md").read_text()
    assert "| 30 | high | 5 | 5 |" in text and "R = 30: 0.012 ± 0.005 m" in text
    assert (tmp_path / "out" / "errors.png").stat().st_size > 10_000
    assert "left out" in result.stderr and "broken" in result.stderr


def test_left_training_region_counts_latent_paths_outside_the_widened_box(tmp_path: Path) -> None:
    from analysis.cgpdm_report import left_training_region

    training = np.zeros((2, 5, 3))
    training[1, :, 0] = 1.0  # box [0, 1] on x1, [0, 0] elsewhere
    latent = np.zeros((4, 5, 3))
    latent[1, 3, 0] = 1.4  # inside [-0.5, 1.5]
    latent[2, 4, 0] = 1.6  # outside
    latent[3, 2, 1] = 1e-9  # outside a box of size 0 on x2
    np.savez(tmp_path / "p.npz", latent=latent, training_latent=training)
    assert left_training_region(tmp_path / "p.npz") == pytest.approx(0.5)
    assert np.isnan(left_training_region(tmp_path / "missing.npz"))
