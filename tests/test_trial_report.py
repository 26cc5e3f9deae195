"""The one line a run prints per trial (mcpilco.trial_report), from summary rows."""

from __future__ import annotations

import math

from mcpilco.trial_report import trial_line


def test_a_learned_trial_reads_as_one_compact_line() -> None:
    row = {
        "trial": 3, "eval_cost": 15.7142857, "success": True, "gp_samples": 240.0,
        "gp_kept": 240.0, "fit_seconds": 4.123, "optimization_steps": 1234.0,
        "optimization_seconds": 310.4, "final_particle_cost": 11.2345,
        "coverage_mean": 0.9133, "trial_seconds": 336.0, "nll_mean": -2.2,
    }  # fmt: skip
    assert trial_line(row, 5) == (
        "trial 3/5  cost 15.71 ✓  GP n=240 fit 4.1 s  Ĵ 11.23 after 1234 steps (310 s)  "
        "coverage 0.91  5.6 min"
    )


def test_exploration_a_reduced_gp_and_a_system_without_success() -> None:
    assert trial_line(
        {"trial": 0, "eval_cost": 60.9, "success": False, "trial_seconds": 0.4}, 5
    ) == ("trial 0 (exploration)  cost 60.9 ✗  0.4 s")
    row = {
        "trial": 2, "mean_error_mm": 3.8, "gp_samples": 600, "gp_kept": 412, "fit_seconds": 9.0,
        "optimization_steps": 10, "optimization_seconds": 2.0, "final_particle_cost": math.nan,
    }  # fmt: skip
    assert trial_line(row, 2) == "trial 2/2  GP n=600 (kept 412) fit 9.0 s  10 steps (2 s)"


def test_a_gymnasium_trial_shows_the_environments_return() -> None:
    row = {"trial": 1, "env_return": -482.077, "env_steps": 34, "terminated": True,
           "trial_seconds": 75.3}  # fmt: skip
    assert trial_line(row, 10) == "trial 1/10  return -482.1 in 34 steps (ended early)  1.3 min"
