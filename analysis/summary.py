"""Per-run learning summary: ``python -m analysis.summary RUN_DIR... [--csv OUT]``.

Reads each run directory's ``summary.csv`` and ``config.yaml`` (as data: nothing in them
is instantiated) and prints one Markdown row per run: kernel, model, seed, trial of first
success, cumulative evaluation cost (2.17) per trial and wall time. Runs that are still
going show the trials finished so far; a system without an evaluation cost or a success
criterion shows "—" for them.

The wall time is the sum of the trials' own times (``trial_seconds``: from the end of the
trial before, or the start of the process that ran it, to its row), so the hours a
stopped run waited before it was resumed are not counted. Rows written before that column
existed count the time since the row before them (the exploration row: nothing) — exact
for a run that was never stopped — except the first row after a resume (the run's
``train.log`` says after which trials it was resumed), which counts the seconds of its
recorded phases (GP fit, policy search, system rollout, logging): the start of its process
is then left out.
"""

from __future__ import annotations

import argparse
import logging
import re
from collections.abc import Iterable
from pathlib import Path

import pandas as pd
from omegaconf import OmegaConf

from analysis.thesis import budget_tag, kernel_label
from mcpilco.errors import RunFileError
from mcpilco.run_contract import TRAIN, find_runs
from mcpilco.run_storage import RunDirectory

log = logging.getLogger("mcpilco.summary")

RESUMED = re.compile(r"resuming .+ after trial (\d+)\s*$")
"""A line of ``train.log`` (:meth:`mcpilco.trial_loop.TrialLoop._restore`)."""
PHASES = ("fit_seconds", "optimization_seconds", "rollout_seconds", "logging_seconds")


def load_run(path: Path) -> dict[str, object]:
    """One run as a flat record (config facts + per-trial eval cost and success)."""
    summary = RunDirectory(path).summary()
    config = OmegaConf.to_container(OmegaConf.load(path / "config.yaml"))
    assert isinstance(config, dict)
    if "success" in summary.columns:
        learned = summary.loc[summary["trial"] > 0]
        first = learned.loc[learned["success"].fillna(False).astype(bool), "trial"]
    else:  # the system reports no success criterion
        first = pd.Series([], dtype=int)
    record: dict[str, object] = {
        "run": str(path),
        "kernel": kernel_label(config["kernel"])
        + (f" [{tag}]" if (tag := budget_tag(config)) else ""),
        "model": str(config["model"]["_target_"]).rsplit(".", 1)[-1],
        "seed": config["seed"],
        "trials_done": int(summary["trial"].max()),
        "first_success": int(first.iloc[0]) if len(first) else None,
        "wall_minutes": wall_seconds(summary, resumed_after(path)) / 60,
    }
    for _, row in summary.iterrows():
        trial = int(row["trial"])
        record[f"cost_T{trial}"] = row.get("eval_cost", float("nan"))
        success = row.get("success")
        record[f"success_T{trial}"] = None if success is None or pd.isna(success) else bool(success)
    return record


def resumed_after(run: Path) -> set[int]:
    """The trials after which the run in ``run`` was resumed, from its ``train.log`` (the
    trial loop's "resuming ... after trial K" lines; none without a log)."""
    log = run / "train.log"
    if not log.is_file():
        return set()
    with log.open(encoding="utf-8", errors="replace") as lines:
        return {int(m.group(1)) for line in lines if (m := RESUMED.search(line))}


def wall_seconds(summary: pd.DataFrame, resumed: Iterable[int] = ()) -> float:
    """A run's wall time (s) from its summary rows, resumed after the trials ``resumed``
    (see the module's docstring)."""
    since_previous = summary["timestamp"].diff().fillna(0.0)
    phases = summary[[c for c in PHASES if c in summary.columns]].fillna(0.0).sum(axis=1)
    after_resume = summary["trial"].isin([k + 1 for k in resumed])
    estimate = since_previous.where(~after_resume, phases)
    if "trial_seconds" in summary.columns:
        estimate = summary["trial_seconds"].fillna(estimate)
    return float(estimate.sum())


def load_runs(paths: Iterable[Path]) -> pd.DataFrame:
    """Every training run directory (one holding ``summary.csv``) under the given paths;
    runs of another kind, and runs whose files are unreadable, are left out with a
    one-line warning."""
    records = []
    for run in find_runs(list(paths), TRAIN):
        try:
            records.append(load_run(run))
        except (RunFileError, OSError, ValueError, KeyError, TypeError) as error:
            reason = str(error).strip().splitlines()[0] if str(error).strip() else ""
            log.warning("%s: unreadable (%s: %s); left out", run, type(error).__name__, reason)
    return pd.DataFrame(records)


def markdown(table: pd.DataFrame) -> str:
    """The README table: one row per run."""
    trials = sorted(int(c.removeprefix("cost_T")) for c in table.columns if c.startswith("cost_T"))
    header = ["kernel", "seed", "first success"] + [f"cost T{t}" for t in trials] + ["wall (min)"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for row in table.sort_values(["kernel", "seed"]).itertuples():
        record = row._asdict()
        costs = []
        for t in trials:
            value = record.get(f"cost_T{t}")
            mark = " ✓" if record.get(f"success_T{t}") is True else ""
            costs.append("—" if pd.isna(value) else f"{value:.1f}{mark}")
        first = "—" if pd.isna(record["first_success"]) else f"T{int(record['first_success'])}"
        lines.append(
            "| "
            + " | ".join(
                [str(record["kernel"]), str(record["seed"]), first, *costs]
                + [f"{record['wall_minutes']:.0f}"]
            )
            + " |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("paths", nargs="+", type=Path, help="run directories or parents")
    parser.add_argument("--csv", type=Path, help="also write the flat table here")
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(message)s")
    table = load_runs(args.paths)
    if table.empty:
        raise SystemExit(f"no training run under {', '.join(map(str, args.paths))}")
    if args.csv:
        table.to_csv(args.csv, index=False)
    print(markdown(table))  # noqa: T201


if __name__ == "__main__":
    main()
