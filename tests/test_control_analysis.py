"""The issue-56 analyses against closed forms: the training-range coverage of a reference
(arccos of a sine's velocity) and the Wilson interval (its formula)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import torch
from omegaconf import OmegaConf

from analysis.control_coverage import coverage_rows
from analysis.control_generalisation import generalisation_table, wilson
from mcpilco.run_storage import RunDirectory

AMPLITUDE, FREQUENCY, SETTLE, DURATION = 0.5, 0.4, 1.0, 5.0


def write_run(root: Path, name: str, target: str, successes: list[bool]) -> Path:
    """A two-joint control run directory: config, run.json, summary (no tracking)."""
    run = root / name
    run.mkdir(parents=True)
    config = {
        "robot": {"num_joints": 2, "home": None},
        "kernel": {"_target_": "mcpilco.kernels.SquaredExponential", "_partial_": True},
        "controller": {"_target_": target},
        "reference": {
            "_target_": "mcpilco.control.SumOfSines",
            "amplitudes": [AMPLITUDE, AMPLITUDE],
            "frequencies": [FREQUENCY, FREQUENCY / 2],
            "duration": DURATION,
            "label": "sines",
        },
        "model_dir": str(root / "model"),
        "task": {"initial_error": 0.0, "settle": SETTLE, "threshold_deg": 1.0},
    }
    OmegaConf.save(OmegaConf.create(config), run / "config.yaml")
    (run / "run.json").write_text('{"kind": "control"}')
    labels = [f"seed_{i}" for i in range(len(successes))] if len(successes) > 1 else ["sines"]
    pd.DataFrame(
        {
            "trial": range(len(successes)),
            "reference": labels,
            "steady_state_max_error_deg_1": [0.2] * len(successes),
            "steady_state_max_error_deg_2": [0.7] * len(successes),
            "success": successes,
            "diverged": [False] * len(successes),
        }
    ).to_csv(run / "summary.csv", index=False)
    return run


def test_velocity_share_outside_the_training_range_is_the_arccos_closed_form(
    tmp_path: Path,
) -> None:
    """Training q̇ within ±v on both joints; joint 1's reference velocity 2πfA cos(2πft)
    exceeds v on the share (2/π) arccos(v / 2πfA) of a whole number of periods (joint
    2, at half the frequency, only where joint 1 does too: v is above its peak)."""
    peak = 2 * math.pi * FREQUENCY * AMPLITUDE
    v = 0.6 * peak  # above joint 2's peak (0.5 of it), below joint 1's
    inputs = torch.zeros(50, 6, dtype=torch.float64)
    inputs[:, :2] = torch.linspace(-1, 1, 50)[:, None]  # q within ±1 rad
    inputs[:, 2:4] = torch.linspace(-v, v, 50)[:, None]
    inputs[:, 4:] = torch.linspace(-100, 100, 50)[:, None]
    model = RunDirectory(tmp_path / "model")
    model.save_tensors(
        "gp.pt", {"gp.train_inputs": inputs, "input_scale": torch.ones(6, dtype=torch.float64)}
    )
    run = write_run(tmp_path, "run", "mcpilco.control.GPFL", [True])
    (row,) = coverage_rows(run)
    expected = (2 / math.pi) * math.acos(v / peak)  # t in [1, 5): 1.6 periods, not whole
    time = np.arange(SETTLE, DURATION, 1e-3)
    exact = np.mean(np.abs(peak * np.cos(2 * math.pi * FREQUENCY * time)) > v)
    assert row["outside_qd"] == pytest.approx(exact, abs=2e-3)
    assert row["outside_qd"] == pytest.approx(expected, abs=0.05)
    assert row["outside_q"] == 0.0 and row["outside_qdd"] == 0.0
    assert row["first_exit_s"] == pytest.approx(0.0, abs=1e-9)  # the peak is at t = 0
    assert row["worst_deg"] == pytest.approx(0.7)


@pytest.mark.parametrize(("successes", "trials"), [(8, 10), (0, 10), (10, 10), (3, 7)])
def test_wilson_interval_is_the_score_formula(successes: int, trials: int) -> None:
    z = 1.959963984540054
    p = successes / trials
    centre = (p + z**2 / (2 * trials)) / (1 + z**2 / trials)
    half = z / (1 + z**2 / trials) * math.sqrt(p * (1 - p) / trials + z**2 / (4 * trials**2))
    assert wilson(successes, trials) == pytest.approx((centre - half, centre + half), abs=1e-9)


def test_successes_on_the_references_true_model_fl_tracks(tmp_path: Path) -> None:
    """The bound column: a GP run's successes counted on the true model's successes."""
    true_run = write_run(tmp_path, "true", "mcpilco.control.TrueModelFL", [True, True, False, True])
    gp_run = write_run(tmp_path, "gp", "mcpilco.control.GPFL", [True, False, True, True])
    table = generalisation_table([true_run, gp_run]).set_index("controller")
    assert table.loc["TrueModelFL", "feasible"] == 3
    assert table.loc["GPFL", "successes"] == 3
    assert table.loc["GPFL", "feasible_successes"] == 2  # seed_2 succeeded but is infeasible
