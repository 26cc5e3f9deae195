"""n_s = 100 with the monitoring signal's bias correction against n_s = 100 without it and the
thesis's n_s = 200, cart-pole, thesis settings otherwise (SE and SP kernels, float64, runs
stopped at their first success or after trial 5): solved by trial, per seed which solved
first, optimisation steps, and where the first reduction came.

    python docs/results/schedule_bias_correction/compare.py [BC_DIR]

BC_DIR (default: this folder) holds the ``bc_{se,sp}_seed_K`` runs; the n_s = 100 runs are
``../schedule_window/w100_*`` (same host kind, code of 1dd3285), the n_s = 200 runs the float64
runs of ``../mixed_precision/recheck_2026-12-05`` (an AVX-512 host, code of 2026-12-05).
A seed's runs are separate draws (rounding differs between code and hosts from the first GP
fit on), so the counts are what compares. Only seeds whose corrected run has stopped count.
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
WINDOW = HERE.parent / "schedule_window"
BASELINE = HERE.parent / "mixed_precision" / "recheck_2026-12-05"
ARMS = {"bc": "n_s = 100 + correction", "w100": "n_s = 100", "f64": "n_s = 200"}


def stopped(run: Path) -> bool:
    """The run ended at its first success or after trial 5."""
    summary = pd.read_csv(run / "summary.csv")
    return bool(summary["success"].iloc[-1]) or int(summary["trial"].iloc[-1]) >= 5


new_runs = sorted(
    p for p in NEW.glob("bc_*_seed_*") if (p / "summary.csv").is_file() and stopped(p)
)
seeds = [(p.name.split("_")[1], int(p.name.rsplit("_", 1)[1])) for p in new_runs]
dirs = {
    "bc": new_runs,
    "w100": [WINDOW / f"w100_{kernel}_seed_{seed}" for kernel, seed in seeds],
    "f64": [BASELINE / f"f64_{kernel}_seed_{seed}" for kernel, seed in seeds],
}
dirs = {arm: [d for d in runs if d.is_dir()] for arm, runs in dirs.items()}
arm_of = {str(d): arm for arm, runs in dirs.items() for d in runs}
trials, _ = load_sweep([d for runs in dirs.values() for d in runs])
trials["arm"] = trials["run"].map(arm_of)
trials["kernel"] = trials["configuration"].str.contains("PI\\+SE").map({True: "SP", False: "SE"})
runs = first_successes(trials)
runs["arm"] = runs["run"].map(arm_of)
print(f"{len(new_runs)} stopped runs with the correction: {', '.join(p.name for p in new_runs)}")
print("(labels: runs without the bias_correction key show '—' for it)\n")
print(solved_by_trial(runs).to_string(index=False), "\n")


def configuration(arm: str, kernel: str) -> str | None:
    """The label of an arm's runs with the SE (``SE``) or PI+SE (``SP``) kernel."""
    mine = runs.loc[(runs["arm"] == arm) & (runs["run"].str.contains(f"_{kernel.lower()}_"))]
    return None if mine.empty else str(mine["configuration"].iloc[0])


for other in ("f64", "w100"):
    outcomes = []
    for kernel in ("SE", "SP"):
        a, b = configuration("bc", kernel), configuration(other, kernel)
        if a is None or b is None:
            continue
        table = paired(runs, a, b)
        outcomes.append(table["earlier"])
        print(f"{kernel}: {ARMS['bc']} (A) against {ARMS[other]} (B)")
        print(table.drop(columns="through_trial").to_string(index=False), "\n")
    tally = pd.concat(outcomes).value_counts() if outcomes else pd.Series(dtype=int)
    wins, losses = int(tally.get("a", 0)), int(tally.get("b", 0))
    print(
        f"both kernels, {ARMS['bc']} against {ARMS[other]}: earlier on {wins}, later on "
        f"{losses}, the same on {int(tally.get('same', 0))}, undecided "
        f"{int(tally.get('undecided', 0))}; two-sided sign test p = {sign_test(wins, losses):.3g}\n"
    )

learned = trials[trials["trial"] >= 1]
until_stop = learned.groupby(["arm", "kernel", "seed"])["optimization_steps"].agg(["sum", "size"])
table = until_stop.unstack("arm").dropna().astype(int)
print("\nSteps (sum) and learned trials (size) until each run stopped:")
print(table.to_string())
print("total steps: " + ", ".join(f"{ARMS[a]} {table[('sum', a)].sum()}" for a in ARMS))
# ms per step at trial k measured alone, one thread, on the AVX2 host of 2026-12-06 (as in
# ../schedule_window/compare.py): an estimate of the optimisation time, one run alone
STEP_MS = {1: 111, 2: 158, 3: 228, 4: 307, 5: 416}
estimate = learned.assign(
    seconds=learned["optimization_steps"] * learned["trial"].map(STEP_MS) / 1e3
)
minutes = estimate.groupby(["arm", "kernel", "seed"])["seconds"].sum().unstack("arm") / 60
print(
    "estimated optimisation minutes until the runs stopped (AVX2 step times), total: "
    + ", ".join(f"{ARMS[a]} {minutes[a].sum():.0f}" for a in ARMS)
)
per_trial = learned.groupby(["arm", "trial"])["optimization_steps"].median().unstack("arm")
print("\nmedian steps per trial:\n" + per_trial.round(0).to_string())

print("\nFirst reduction of each trace (the signal starts at 0, inside σ_s):")
for arm, window in (("bc", 100), ("w100", 100), ("f64", 200)):
    traces = pd.DataFrame([row for run in dirs[arm] for row in trial_rows(run, 0.01)])
    first = traces["reductions_at"].str.split().str[0].astype(float)
    after = (traces["steps"] - traces["steps_to_final"]) / traces["steps"]
    print(
        f"  {ARMS[arm]}: at step n_s = {window} exactly in {int((first == window).sum())} of "
        f"{len(traces)} traces, median first reduction {first.median():g}; share of a trace's "
        f"steps after Ĵ settled: median {after.median():.2f}"
    )
