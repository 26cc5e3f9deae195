"""The session-24 rule on the run directories of this folder: per precision, the runs
solved by trial 2..5 over seeds 0..9 of both kernels, per seed which solved first, and the
verdict (mixed becomes the default only if its count is at least float64's at every trial).

    python docs/results/mixed_precision/recheck_2026-12-05/pooled.py [RUNS_DIR]

(RUNS_DIR: where the run directories are; default this folder.)
"""

from __future__ import annotations

import sys
from pathlib import Path

from analysis.first_success import first_successes, paired_markdown, solved_by_trial
from analysis.report import load_sweep

HERE = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parent
SEEDS = range(10)
runs_dirs = [HERE / f"{p}{k}_seed_{s}" for p in ("", "f64_") for k in ("se", "sp") for s in SEEDS]
missing = [d.name for d in runs_dirs if not (d / "summary.csv").is_file()]
trials, _ = load_sweep([d for d in runs_dirs if d.is_dir()])
runs = first_successes(trials)
runs["precision"] = ["mixed" if "float32 rollout" in c else "float64" for c in runs["configuration"]]
print(f"runs: {len(runs)} (missing: {', '.join(missing) or 'none'})\n")
by_precision = solved_by_trial(runs.assign(configuration=runs["precision"])).set_index(["configuration", "trial"])
counts = {p: [int(by_precision.at[(p, k), "solved"]) for k in (2, 3, 4, 5)] for p in ("float64", "mixed")}
for precision, group in runs.groupby("precision"):
    unfinished = group[group["first_success"].isna() & (group["last_trial"] < 5)]
    print(f"{precision}: solved by T2/T3/T4/T5 {' / '.join(map(str, counts[precision]))} of "
          f"{len(group)} (unfinished without success: {', '.join(unfinished['run'].map(lambda r: Path(r).name)) or 'none'})")
print()
print(solved_by_trial(runs.drop(columns="precision")).to_string(index=False))
print()
print(paired_markdown(runs.drop(columns="precision")))
if missing or any(runs["first_success"].isna() & (runs["last_trial"] < 5)):
    print("verdict: not yet (runs missing or unfinished)")
    sys.exit(0)
ahead = all(m >= f for m, f in zip(counts["mixed"], counts["float64"]))
print("verdict:", "mixed becomes the default" if ahead else "float64 stays the default")
