"""analysis.campaign: runs taken one trial at a time to their first success, resumable,
against a stand-in for runners.train that writes summary rows from a fixed script of
outcomes (so the expected calls are known independently of the loop)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from analysis.campaign import main, parse_seeds, plan, run_campaign
from mcpilco.errors import ConfigError

SOLVES_AT = {"se_seed_0": 2, "se_seed_1": None, "sp_seed_0": 1, "sp_seed_1": 3, "seed_0": 1}


class FakeTrain:
    """Appends the summary rows ``runners.train num_trials=k`` would: trial 0 (exploration)
    first, then learned trials up to k, succeeding from the run's scripted trial on."""

    def __init__(self, fail_on: str | None = None) -> None:
        self.calls: list[list[str]] = []
        self.fail_on = fail_on

    def __call__(self, argv: list[str], output: Path) -> int:
        self.calls.append(argv)
        options = dict(a.split("=", 1) for a in argv[3:])
        run_dir = Path(options.get("hydra.run.dir") or options["resume"])
        if run_dir.name == self.fail_on:
            return 1
        run_dir.mkdir(parents=True, exist_ok=True)
        summary = run_dir / "summary.csv"
        done = pd.read_csv(summary)["trial"].max() if summary.is_file() else -1
        first = SOLVES_AT[run_dir.name]
        rows = [
            {"trial": t, "success": t >= 1 and first is not None and t >= first}
            for t in range(done + 1, int(options["num_trials"]) + 1)
        ]
        pd.DataFrame(rows).to_csv(summary, mode="a", header=not summary.is_file(), index=False)
        return 0


def test_plan_and_seeds():
    assert parse_seeds("0-2,7") == [0, 1, 2, 7]
    runs = plan(["kernel=se,sp"], [0, 1], ["protocol=quick"])
    assert [r.name for r in runs] == ["se_seed_0", "se_seed_1", "sp_seed_0", "sp_seed_1"]
    assert runs[1].overrides == ("kernel=se", "seed=1", "protocol=quick")
    with pytest.raises(ConfigError, match="--seeds='a-b'"):
        parse_seeds("a-b")
    with pytest.raises(ConfigError, match="--axis='seed=1,2'"):
        plan(["seed=1,2"], [0], [])


def test_each_run_stops_at_its_first_success_and_a_repeat_does_nothing(tmp_path):
    fake = FakeTrain()
    runs = plan(["kernel=se,sp"], [0, 1], [])
    outcome = run_campaign(tmp_path, runs, max_trials=5, launch=fake)
    assert outcome == {
        "se_seed_0": (2, True),
        "se_seed_1": (5, False),
        "sp_seed_0": (1, True),
        "sp_seed_1": (3, True),
    }
    # calls per run: one first call (num_trials=1), then one resume per further trial
    per_run = {}
    for argv in fake.calls:
        options = dict(a.split("=", 1) for a in argv[3:])
        name = Path(options.get("hydra.run.dir") or options["resume"]).name
        per_run.setdefault(name, []).append(("resume" in options, int(options["num_trials"])))
    assert per_run["se_seed_1"] == [(False, 1), (True, 2), (True, 3), (True, 4), (True, 5)]
    assert per_run["sp_seed_0"] == [(False, 1)]
    assert "kernel=sp" in fake.calls[len(per_run["se_seed_0"]) + 5][3:]
    again = FakeTrain()
    assert run_campaign(tmp_path, runs, max_trials=5, launch=again) == outcome
    assert again.calls == []
    assert len((tmp_path / "progress.log").read_text().splitlines()) == len(fake.calls)


def test_a_killed_campaign_continues_where_it_stopped_and_a_failing_run_does_not_block(tmp_path):
    runs = plan(["kernel=se"], [0, 1], [])
    run_campaign(tmp_path, runs[:1], max_trials=1, launch=FakeTrain())  # stopped after trial 1
    fake = FakeTrain(fail_on="se_seed_0")
    outcome = run_campaign(tmp_path, runs, max_trials=5, launch=fake)
    assert outcome["se_seed_0"] == (1, False)
    assert outcome["se_seed_1"] == (5, False)
    assert "resume=" in fake.calls[0][3] and fake.calls[0][4:] == ["threads=1", "num_trials=2"]


def test_all_trials_runs_past_success_and_bad_input_is_one_line(tmp_path, caplog):
    outcome = run_campaign(tmp_path, plan([], [0], []), 3, until_success=False, launch=FakeTrain())
    assert outcome == {"seed_0": (3, True)}
    assert main([str(tmp_path), "--max-trials", "0"]) == 2
    assert "--max-trials=0" in caplog.text
