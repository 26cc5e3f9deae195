"""Queue runs one trial at a time until each succeeds: the thesis's "trials to solve" studies.

``python -m analysis.campaign RUNS_DIR --seeds 0-9 --axis kernel=se,sp [--set KEY=VALUE ...]``

Every combination of the axes and seeds is one run directory ``RUNS_DIR/<axis values>_seed_<s>``
(e.g. ``se_seed_3``). Each run is taken one trial at a time (``runners.train num_trials=k``, then
``resume=`` for ``k + 1``) until its first successful learned trial or ``--max-trials``
(default 5); ``--all-trials`` runs every run to ``--max-trials`` regardless. A campaign is
resumable: a run directory that already holds trials continues from its ``summary.csv``,
and a finished one is skipped, so the same command may be repeated after a kill, or on
another machine sharing ``RUNS_DIR``. Progress is appended to ``RUNS_DIR/progress.log``,
each run's output to ``RUNS_DIR/<name>.out``. ``--set`` overrides go to each run's first
call only (a resumed run keeps its saved config). Tally with ``python -m
analysis.first_success RUNS_DIR``.

Run processes side by side with several campaigns over disjoint seeds (one per core, each
with ``--threads 1``).
"""

from __future__ import annotations

import argparse
import itertools
import logging
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from mcpilco.errors import ConfigError

log = logging.getLogger("mcpilco.campaign")

Launch = Callable[[list[str], Path], int]
"""Runs one command (argv) with its output appended to a file; returns the exit status."""


@dataclass(frozen=True)
class PlannedRun:
    """One run of a campaign: its folder name and the overrides of its first call."""

    name: str
    overrides: tuple[str, ...]


def parse_seeds(text: str) -> list[int]:
    """``0-9`` or ``0,3,5`` or ``2-4,8`` → the seeds; ConfigError naming the value."""
    seeds: list[int] = []
    try:
        for part in text.split(","):
            low, _, high = part.partition("-")
            seeds += list(range(int(low), int(high or low) + 1))
    except ValueError:
        raise ConfigError(f"--seeds={text!r}: expected e.g. 0-9 or 0,3,5") from None
    if not seeds or min(seeds) < 0:
        raise ConfigError(f"--seeds={text!r}: expected non-negative seeds")
    return seeds


def plan(axes: Sequence[str], seeds: Sequence[int], fixed: Sequence[str]) -> list[PlannedRun]:
    """Every combination of ``axes`` (``key=v1,v2``) and ``seeds``, each with ``fixed``."""
    parsed = []
    for axis in axes:
        key, _, values = axis.partition("=")
        if not key or not values or "seed" == key:
            raise ConfigError(f"--axis={axis!r}: expected KEY=V1,V2 (and seeds with --seeds)")
        parsed.append([(key, v) for v in values.split(",")])
    runs = []
    for combination in itertools.product(*parsed):
        for seed in seeds:
            label = "_".join(v.replace("/", "-") for _, v in combination)
            name = f"{label}_seed_{seed}" if label else f"seed_{seed}"
            overrides = tuple(f"{k}={v}" for k, v in combination) + (f"seed={seed}", *fixed)
            runs.append(PlannedRun(name, overrides))
    return runs


def progress(run_dir: Path) -> tuple[int, bool]:
    """The last finished trial of a run directory (-1: none) and whether a learned trial
    (≥ 1) succeeded."""
    summary = run_dir / "summary.csv"
    if not summary.is_file():
        return -1, False
    table = pd.read_csv(summary)
    if table.empty:
        return -1, False
    learned = table[table["trial"] >= 1]
    solved = "success" in table and bool(learned["success"].astype("boolean").fillna(False).any())
    return int(table["trial"].max()), solved


def subprocess_launch(argv: list[str], output: Path) -> int:
    with output.open("a") as sink:
        return subprocess.run(argv, stdout=sink, stderr=subprocess.STDOUT).returncode


def run_campaign(
    runs_dir: Path,
    runs: Sequence[PlannedRun],
    max_trials: int,
    until_success: bool = True,
    threads: int = 1,
    launch: Launch = subprocess_launch,
    python: str = sys.executable,
) -> dict[str, tuple[int, bool]]:
    """Take every run to its first success (or ``max_trials``); returns per run name its
    last trial and whether it succeeded. A run whose command fails is left where it
    stopped (its ``failed.txt`` says why) and the campaign goes on with the next."""
    runs_dir.mkdir(parents=True, exist_ok=True)
    journal = runs_dir / "progress.log"
    outcome = {}
    for run in runs:
        directory = runs_dir / run.name
        last, solved = progress(directory)
        while last < max_trials and not (until_success and solved):
            target = max(last + 1, 1)
            common = [f"threads={threads}", f"num_trials={target}"]
            if last < 0:
                argv = [
                    python,
                    "-m",
                    "runners.train",
                    *run.overrides,
                    *common,
                    f"hydra.run.dir={directory}",
                ]
            else:
                argv = [python, "-m", "runners.train", f"resume={directory}", *common]
            started = time.monotonic()
            status = launch(argv, runs_dir / f"{run.name}.out")
            new_last, solved = progress(directory)
            line = (
                f"{time.strftime('%F %T')} {run.name} trial {new_last} success={solved} "
                f"({time.monotonic() - started:.0f} s, exit {status})"
            )
            with journal.open("a") as sink:
                sink.write(line + "\n")
            log.info("%s", line)
            if status != 0 or new_last <= last:
                log.warning(
                    "%s stopped at trial %d (exit %d): see %s.out",
                    run.name,
                    new_last,
                    status,
                    run.name,
                )
                break
            last = new_last
        outcome[run.name] = (last, solved)
    return outcome


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("runs_dir", type=Path)
    parser.add_argument("--seeds", default="0-9", help="e.g. 0-9 or 0,3,5 (default 0-9)")
    parser.add_argument("--axis", action="append", default=[], help="KEY=V1,V2: one run per value")
    parser.add_argument(
        "--set", action="append", default=[], dest="fixed", help="KEY=VALUE for every run"
    )
    parser.add_argument("--max-trials", type=int, default=5)
    parser.add_argument(
        "--all-trials", action="store_true", help="do not stop at the first success"
    )
    parser.add_argument("--threads", type=int, default=1, help="torch threads per run (default 1)")
    parser.add_argument("--dry-run", action="store_true", help="list the runs and stop")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    try:
        if args.max_trials < 1:
            raise ConfigError(f"--max-trials={args.max_trials}: expected at least 1")
        runs = plan(args.axis, parse_seeds(args.seeds), args.fixed)
    except ConfigError as error:
        log.error("%s", error)
        return 2
    if args.dry_run:
        for run in runs:
            last, solved = progress(args.runs_dir / run.name)
            log.info(
                "%s: %s (done through trial %d, solved %s)",
                run.name,
                " ".join(run.overrides),
                last,
                solved,
            )
        return 0
    outcome = run_campaign(args.runs_dir, runs, args.max_trials, not args.all_trials, args.threads)
    solved = sum(s for _, s in outcome.values())
    log.info(
        "%d of %d runs solved; tally: python -m analysis.first_success %s",
        solved,
        len(outcome),
        args.runs_dir,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
