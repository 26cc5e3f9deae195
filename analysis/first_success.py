"""First-success trials of a sweep: solved-by-trial counts per configuration and paired
comparisons of two configurations run on the same seeds.

Runs may stop at their first success (one trial at a time, as the thesis's "trials to
solve" studies do) or be unfinished; both are handled by counting, for trial k, only the
runs observed through k: solved at or before k, or with trial k finished. A seed compared
between two configurations is decided only as far as both runs were observed.
"""

from __future__ import annotations

import argparse
import math
import sys
from itertools import combinations
from pathlib import Path

import pandas as pd

from analysis.stats import rate_with_interval, sign_test, wilson_interval
from analysis.sweep import load_sweep


def first_successes(trials: pd.DataFrame) -> pd.DataFrame:
    """One row per run: configuration, seed, run, ``last_trial`` (the last finished trial)
    and ``first_success`` (the first learned trial whose policy succeeded, or <NA>), from
    :func:`analysis.sweep.load_sweep`'s table (one row per run and trial, with ``success``)."""
    records = []
    for (configuration, seed, run), group in trials.groupby(["configuration", "seed", "run"]):
        learned = group[group["trial"] >= 1]
        solved = learned.loc[learned["success"].astype(bool), "trial"]
        records.append(
            {
                "configuration": configuration,
                "seed": int(seed),
                "run": run,
                "last_trial": int(group["trial"].max()),
                "first_success": int(solved.min()) if len(solved) else pd.NA,
            }
        )
    return pd.DataFrame(records).astype({"first_success": "Int64"})


def solved_by_trial(runs: pd.DataFrame) -> pd.DataFrame:
    """Per configuration and trial k (1 to the last trial any of its runs reached): the runs
    observed through k, those solved by k, the rate and its Wilson 95 % interval."""
    records = []
    for configuration, group in runs.groupby("configuration"):
        first = group["first_success"]
        for trial in range(1, int(group["last_trial"].max()) + 1):
            solved = int((first <= trial).fillna(False).sum())
            observed = int(((first <= trial).fillna(False) | (group["last_trial"] >= trial)).sum())
            low, high = wilson_interval(solved, observed)
            records.append(
                {
                    "configuration": configuration,
                    "trial": trial,
                    "observed": observed,
                    "solved": solved,
                    "rate": solved / observed if observed else math.nan,
                    "wilson_low": low,
                    "wilson_high": high,
                }
            )
    return pd.DataFrame(records)


def solved_markdown(table: pd.DataFrame) -> str:
    lines = [
        "| configuration | trial | solved by this trial | rate [Wilson 95 %] |",
        "|---|---|---|---|",
    ]
    for row in table.itertuples():
        lines.append(
            f"| {row.configuration} | {row.trial} | {row.solved}/{row.observed} | "
            f"{rate_with_interval(row.rate, row.wilson_low, row.wilson_high)} |"
        )
    return "\n".join(lines) + "\n"


def compare_seed(
    first_a: int | None, last_a: int, first_b: int | None, last_b: int
) -> tuple[str, int]:
    """Which of two runs of one seed solved first: ``a``, ``b``, ``same`` or ``undecided``
    (one of them unfinished before the other's success, or both unsolved over different
    horizons), and the trial through which the comparison holds."""
    a = first_a if first_a is not None else math.inf
    b = first_b if first_b is not None else math.inf
    seen_a = first_a if first_a is not None else last_a  # observed through this trial
    seen_b = first_b if first_b is not None else last_b
    horizon = min(seen_a, seen_b)
    if a == b != math.inf:
        return "same", int(a)
    if min(a, b) > horizon:  # neither solved within what both runs show
        return ("same" if seen_a == seen_b else "undecided"), int(horizon)
    return ("a" if a < b else "b"), int(min(a, b))


def paired(runs: pd.DataFrame, a: str, b: str) -> pd.DataFrame:
    """Per seed run in both configurations ``a`` and ``b`` (one run each; the first by run
    directory if a seed was run twice): both first successes and :func:`compare_seed`."""
    one = runs.sort_values("run").drop_duplicates(["configuration", "seed"])
    left = one[one["configuration"] == a].set_index("seed")
    right = one[one["configuration"] == b].set_index("seed")
    records = []
    for seed in sorted(set(left.index) & set(right.index)):
        first_a, first_b = left.at[seed, "first_success"], right.at[seed, "first_success"]
        outcome, through = compare_seed(
            None if pd.isna(first_a) else int(first_a),
            int(left.at[seed, "last_trial"]),
            None if pd.isna(first_b) else int(first_b),
            int(right.at[seed, "last_trial"]),
        )
        records.append(
            {
                "seed": seed,
                "first_a": first_a,
                "last_a": int(left.at[seed, "last_trial"]),
                "first_b": first_b,
                "last_b": int(right.at[seed, "last_trial"]),
                "earlier": outcome,
                "through_trial": through,
            }
        )
    return pd.DataFrame(records)


def _first(first: object, last: int) -> str:
    return f"— (through T{last})" if pd.isna(first) else f"T{first}"


def paired_markdown(runs: pd.DataFrame, min_seeds: int = 2) -> str:
    """Every pair of configurations sharing at least ``min_seeds`` seeds: per seed which
    solved first, the counts and the sign test's p."""
    sections = []
    for a, b in combinations(sorted(runs["configuration"].unique()), 2):
        table = paired(runs, a, b)
        if len(table) < min_seeds:
            continue
        counts = table["earlier"].value_counts()
        wins, losses = int(counts.get("a", 0)), int(counts.get("b", 0))

        lines = [
            f"### A = {a}; B = {b}",
            "",
            "| seed | A first success | B first success | earlier |",
            "|---|---|---|---|",
        ]
        for row in table.itertuples():
            earlier = {"a": "A", "b": "B"}.get(row.earlier, row.earlier)
            lines.append(
                f"| {row.seed} | {_first(row.first_a, row.last_a)} | "
                f"{_first(row.first_b, row.last_b)} | {earlier} |"
            )
        lines += [
            "",
            f"A earlier on {wins}, B earlier on {losses}, the same on "
            f"{int(counts.get('same', 0))}, undecided {int(counts.get('undecided', 0))} of "
            f"{len(table)} seeds; two-sided sign test p = {sign_test(wins, losses):.3g}.",
            "",
        ]
        sections.append("\n".join(lines))
    return "\n".join(sections)


def main(argv: list[str] | None = None) -> int:
    """``python -m analysis.first_success RUNS_DIR... [--csv OUT]``: solved by trial per
    configuration (with Wilson intervals) and, per pair of configurations on the same
    seeds, which solved first and the sign test — the tally of an ``analysis.campaign``."""
    parser = argparse.ArgumentParser(
        description="Solved-by-trial counts and paired seed comparisons."
    )
    parser.add_argument(
        "paths", nargs="+", type=Path, help="run directories or folders holding them"
    )
    parser.add_argument("--csv", type=Path, default=None, help="also write the per-run table here")
    args = parser.parse_args(argv)
    trials, failed = load_sweep(args.paths)
    if trials.empty or "success" not in trials.columns:
        sys.stderr.write(
            f"no finished trials with a success criterion under {', '.join(map(str, args.paths))}\n"
        )
        return 2
    runs = first_successes(trials)
    if args.csv is not None:
        runs.to_csv(args.csv, index=False)
    unfinished = runs[runs["first_success"].isna()]
    sys.stdout.write(
        f"{len(runs)} runs; unsolved so far: {len(unfinished)}; failed: {len(failed)}\n\n"
    )
    sys.stdout.write(solved_markdown(solved_by_trial(runs)) + "\n")
    sys.stdout.write(paired_markdown(runs))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
