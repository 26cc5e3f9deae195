"""The tables of a Gymnasium study: ``env_return`` per trial over seeds, and each seed's
learned policy scored on fresh episodes.

    python -m analysis.gym_report STUDY_DIR [--trial K]

``STUDY_DIR`` holds training runs of one preset (one per seed, ``summary.csv`` each);
``--trial K`` (default: the last trial every run finished) reads each run's
``evaluation/trial_KK.json`` (``python -m analysis.evaluate RUN --trial K --episodes N``).
Runs are read as data; nothing in them is built.
"""

from __future__ import annotations

import argparse
import json
import logging
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from mcpilco.run_contract import TRAIN, find_runs

log = logging.getLogger("mcpilco.gym_report")


def load_summaries(study: Path) -> pd.DataFrame:
    """Every run's summary rows with ``seed`` and ``run`` columns (seed from config.yaml)."""
    frames = []
    for run in find_runs([study], TRAIN):
        table = pd.read_csv(run / "summary.csv")
        if "env_return" not in table:
            log.warning("%s: no env_return column (not a Gymnasium run); left out", run)
            continue
        config = yaml.safe_load((run / "config.yaml").read_text())
        frames.append(table.assign(seed=int(config["seed"]), run=str(run)))
    if not frames:
        raise SystemExit(f"no Gymnasium training runs under {study}")
    return pd.concat(frames, ignore_index=True)


def returns_markdown(summaries: pd.DataFrame) -> str:
    """Per trial: seeds, median env_return with its range, environment steps used so far
    (median over seeds, exploration included), median wall time of the trial."""
    summaries = summaries.sort_values(["seed", "trial"]).copy()
    summaries["steps_so_far"] = summaries.groupby("seed")["env_steps"].cumsum()
    lines = [
        "| trial | seeds | env_return: median | min | max | environment steps so far | "
        "trial wall (s), median |",
        "|---|---|---|---|---|---|---|",
    ]
    for trial, part in summaries.groupby("trial"):
        lines.append(
            f"| {trial} | {len(part)} | {part.env_return.median():.1f} | "
            f"{part.env_return.min():.1f} | {part.env_return.max():.1f} | "
            f"{part.steps_so_far.median():.0f} | {part.trial_seconds.median():.0f} |"
        )
    return "\n".join(lines) + "\n"


def load_evaluations(study: Path, trial: int) -> pd.DataFrame:
    """One row per run with an ``evaluation/trial_KK.json``: seed, episodes, steps, the
    mean env_return, its 95 % half-width and its worst episode."""
    rows = []
    for run in find_runs([study], TRAIN):
        path = run / "evaluation" / f"trial_{trial:02d}.json"
        if not path.is_file():
            log.warning("%s: no evaluation of trial %d; left out", run, trial)
            continue
        result = json.loads(path.read_text())
        returns = np.array([r["env_return"] for r in result["system_runs"]], dtype=float)
        seed = int(yaml.safe_load((run / "config.yaml").read_text())["seed"])
        metrics = result["system_metrics"]["env_return"]
        rows.append(
            {"seed": seed, "episodes": len(returns), "steps": result.get("steps"),
             "mean": float(returns.mean()), "ci95": float(metrics.get("ci95", np.nan)),
             "worst": float(returns.min()), "eval_seed": result["seed"]}
        )  # fmt: skip
    return pd.DataFrame(rows).sort_values("seed") if rows else pd.DataFrame()


def evaluation_markdown(evaluations: pd.DataFrame, trial: int, target: float = -200.0) -> str:
    lines = [
        f"| seed | episodes (steps each) | env_return at trial {trial}: mean ± 95 % | worst | "
        f"≥ {target:g} |",
        "|---|---|---|---|---|",
    ]
    for row in evaluations.itertuples():
        mark = "yes" if row.mean >= target else "no"
        lines.append(
            f"| {row.seed} | {row.episodes} ({row.steps}) | {row.mean:.1f} ± {row.ci95:.1f} | "
            f"{row.worst:.1f} | {mark} |"
        )
    if len(evaluations):
        reached = int((evaluations["mean"] >= target).sum())
        lines.append(
            f"| all | {int(evaluations.episodes.sum())} | {evaluations['mean'].mean():.1f} "
            f"(mean of the seeds' means; median {evaluations['mean'].median():.1f}) | "
            f"{evaluations.worst.min():.1f} | {reached} of {len(evaluations)} |"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("study", type=Path)
    parser.add_argument("--trial", type=int, help="the evaluated trial (default: the last)")
    parser.add_argument("--target", type=float, default=-200.0, help="the return to reach")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    summaries = load_summaries(args.study)
    trial = args.trial
    if trial is None:
        trial = int(summaries.groupby("seed")["trial"].max().min())
    log.info("%s", returns_markdown(summaries))
    evaluations = load_evaluations(args.study, trial)
    log.info("%s", evaluation_markdown(evaluations, trial, args.target))


if __name__ == "__main__":
    main()
