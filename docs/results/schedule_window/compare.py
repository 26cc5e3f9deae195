"""n_s = 100 against the thesis's n_s = 200 (``optimizer.schedule.window``), cart-pole, thesis
settings otherwise (SE and SP kernels, float64, runs stopped at their first success or after
trial 5): solved by trial, per seed which solved first, and the optimisation steps spent.

    python docs/results/schedule_window/compare.py [WINDOW100_DIR]

WINDOW100_DIR (default: this folder) holds the ``w100_{se,sp}_seed_K`` runs; the n_s = 200
runs are the float64 runs of ``docs/results/mixed_precision/recheck_2026-12-05`` (same
protocol, code of 2026-12-05, another host: a seed's two runs are not the same run up to
the window — rounding differs between hosts — so the per-seed pairs are two draws, and the
counts are what compares).
"""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

from analysis.first_success import first_successes, paired, solved_by_trial
from analysis.stats import sign_test
from analysis.sweep import load_sweep
from analysis.wasted_steps import trial_rows

HERE = Path(__file__).resolve().parent
NEW = Path(sys.argv[1]) if len(sys.argv) > 1 else HERE
BASELINE = HERE.parent / "mixed_precision" / "recheck_2026-12-05"

new_runs = sorted(p for p in NEW.glob("w100_*_seed_*") if (p / "summary.csv").is_file())
seeds = {(p.name.split("_")[1], int(p.name.rsplit("_", 1)[1])) for p in new_runs}
baseline_runs = [BASELINE / f"f64_{kernel}_seed_{seed}" for kernel, seed in sorted(seeds)]
trials, _ = load_sweep([*new_runs, *baseline_runs])
runs = first_successes(trials)
print(f"{len(new_runs)} runs with n_s = 100 and their seeds' n_s = 200 runs\n")
print(solved_by_trial(runs).to_string(index=False), "\n")
outcomes = []
for kernel in ("SE", "PI+SE"):
    a, b = (f"S.I., {kernel}, dropout, l=(3,1) [optimizer.schedule.window={w}]" for w in (100, 200))
    table = paired(runs, a, b)
    outcomes.append(table["earlier"])
    print(f"{kernel}: n_s = 100 (A) against n_s = 200 (B)")
    print(table.drop(columns="through_trial").to_string(index=False), "\n")
counts = pd.concat(outcomes).value_counts()
wins, losses = int(counts.get("a", 0)), int(counts.get("b", 0))
print(
    f"both kernels: n_s = 100 earlier on {wins}, n_s = 200 earlier on {losses}, the same on "
    f"{int(counts.get('same', 0))}, undecided {int(counts.get('undecided', 0))}; "
    f"two-sided sign test p = {sign_test(wins, losses):.3g}"
)

learned = trials[trials["trial"] >= 1].copy()
learned["window"] = learned["configuration"].str.extract(r"window=(\d+)")[0].astype(int)
learned["kernel"] = learned["configuration"].str.contains("PI\\+SE").map({True: "SP", False: "SE"})
# only trials both windows' runs of a seed reached are compared step by step
reached = learned.groupby(["kernel", "seed", "trial"])["window"].nunique().eq(2)
both = learned.set_index(["kernel", "seed", "trial"]).loc[reached[reached].index].reset_index()
per_trial = both.pivot_table(
    index=["kernel", "seed", "trial"], columns="window", values="optimization_steps"
)
print("\nOptimisation steps per trial where both runs of a seed reached it:\n")
print(per_trial.astype(int).to_string())
totals = per_trial.sum()
print(
    f"\nsum over those {len(per_trial)} trials: n_s = 200 {int(totals[200])}, "
    f"n_s = 100 {int(totals[100])} ({100 * (totals[100] / totals[200] - 1):+.0f} %)"
)
by_trial = per_trial.groupby(level="trial").median()
print("median per trial:\n" + by_trial.astype(int).to_string())
finished = runs.loc[runs["first_success"].notna() | (runs["last_trial"] >= 5), "run"]
done = learned[learned["run"].isin(finished)]
until_stop = done.groupby(["window", "kernel", "seed"])["optimization_steps"].agg(["sum", "size"])
table = until_stop.unstack("window").dropna().astype(int)
print("\nSteps (sum) and learned trials (size) until the run stopped (first success or trial 5),")
print("seeds whose runs of both windows have stopped:")
print(table.to_string())
print(f"total steps: n_s = 100 {table[('sum', 100)].sum()}, n_s = 200 {table[('sum', 200)].sum()}")
# ms per step at trial k (GP of 60 k points) measured alone, one thread, on the AVX2 host of
# 2026-12-06 (optimization_seconds / optimization_steps of the 5-trial SE seed-0 run in
# docs/results/forward_gradient/avx2_2026-12-06/whole_se0/summary.csv): an estimate of the
# optimisation time these steps would take there, one run alone
STEP_MS = {1: 111, 2: 158, 3: 228, 4: 307, 5: 416}
done = done.assign(estimate=done["optimization_steps"] * done["trial"].map(STEP_MS) / 1e3)
minutes = done.groupby(["window", "kernel", "seed"])["estimate"].sum().unstack("window") / 60
minutes = minutes.loc[table.index]
print("estimated optimisation minutes until the run stopped (AVX2 host's step times):")
print(minutes.round(1).to_string())
print(f"sum: n_s = 100 {minutes[100].sum():.0f} min, n_s = 200 {minutes[200].sum():.0f} min")
share = learned.assign(
    after=(learned["optimization_steps"] - learned["steps_to_final"])
    / learned["optimization_steps"]
)
print("\nShare of a trial's steps after Ĵ came within 1 % of its final value (median, all trials):")
print(share.groupby("window")["after"].median().round(3).to_string())
print("\nTraces whose first reduction came at step n_s exactly (the signal starts at 0, inside")
print("the threshold, so the first n_s steps count towards a reduction whatever the cost does):")
for window, dirs in ((100, new_runs), (200, baseline_runs)):
    traces = pd.DataFrame([row for run in dirs for row in trial_rows(run, 0.01)])
    first = traces["reductions_at"].str.split().str[0].astype(int)
    print(f"  n_s = {window}: {int((first == window).sum())} of {len(traces)}")
