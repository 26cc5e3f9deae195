"""analysis.gym_report on synthetic Gymnasium runs with known returns."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

from analysis.gym_report import (
    evaluation_markdown,
    load_evaluations,
    load_summaries,
    returns_markdown,
)


def write_run(root: Path, seed: int, returns: list[float], evaluation: list[float]) -> None:
    run = root / f"seed_{seed}"
    (run / "evaluation").mkdir(parents=True)
    (run / "config.yaml").write_text(f"seed: {seed}\nsystem:\n  env_id: Pendulum-v1\n")
    (run / "run.json").write_text('{"kind": "train"}')
    pd.DataFrame({
        "trial": range(len(returns)), "env_return": returns, "env_steps": 100,
        "trial_seconds": [1.0 + seed] * len(returns),
    }).to_csv(run / "summary.csv", index=False)  # fmt: skip
    runs = [{"initial_state": [0.0, 0.0], "env_return": r, "env_steps": 200} for r in evaluation]
    result = {"trial": 2, "runs": len(runs), "steps": 200, "seed": 1000, "system_runs": runs,
              "system_metrics": {"env_return": {"mean": sum(evaluation) / len(evaluation),
                                                "ci95": 12.5}}}  # fmt: skip
    (run / "evaluation" / "trial_02.json").write_text(json.dumps(result))


def test_returns_per_trial_and_the_fresh_episode_scores(tmp_path: Path) -> None:
    write_run(tmp_path, 1, [-700.0, -300.0, -150.0], [-100.0, -140.0])
    write_run(tmp_path, 2, [-650.0, -500.0, -250.0], [-300.0, -200.0])
    write_run(tmp_path, 3, [-600.0, -400.0, -120.0], [-180.0, -160.0])
    text = returns_markdown(load_summaries(tmp_path))
    # trial 1: returns -300, -500, -400: median -400; 200 steps so far on every seed
    assert "| 1 | 3 | -400.0 | -500.0 | -300.0 | 200 | 3 |" in text
    assert "| 2 | 3 | -150.0 | -250.0 | -120.0 | 300 | 3 |" in text
    evaluations = load_evaluations(tmp_path, 2)
    assert evaluations["mean"].tolist() == [-120.0, -250.0, -170.0]
    table = evaluation_markdown(evaluations, 2)
    assert "| 1 | 2 (200) | -120.0 ± 12.5 | -140.0 | yes |" in table
    assert "| 2 | 2 (200) | -250.0 ± 12.5 | -300.0 | no |" in table
    assert (
        "| all | 6 | -180.0 (mean of the seeds' means; median -170.0) | -300.0 | 2 of 3 |" in table
    )
