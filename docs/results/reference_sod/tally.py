"""Part 2 of the reference_sod page: runs solved by trial 2..5 over seeds 0..9 of both
kernels, float64 without reduction (../mixed_precision/recheck_2026-12-05/f64_*) against
float64 with the reference SoD (sod_*_seed_*), per seed which solved first, and the rule.

    python docs/results/reference_sod/tally.py
"""

from __future__ import annotations

import sys
from pathlib import Path

from analysis.first_success import first_successes, paired_markdown, solved_by_trial
from analysis.report import load_sweep

HERE = Path(__file__).resolve().parent
BASE = HERE.parent / "mixed_precision" / "recheck_2026-12-05"
dirs = [BASE / f"f64_{k}_seed_{s}" for k in ("se", "sp") for s in range(10)]
sod = {("se", 0): "sod_se0"}  # SE seed 0: the 5-trial run of part 1
dirs += [HERE / sod.get((k, s), f"sod_{k}_seed_{s}") for k in ("se", "sp") for s in range(10)]
missing = [d.name for d in dirs if not (d / "summary.csv").is_file()]
trials, _ = load_sweep([d for d in dirs if d.is_dir()])
runs = first_successes(trials)
runs["setting"] = ["SoD" if "reduction" in c else "all samples" for c in runs["configuration"]]
by = solved_by_trial(runs.assign(configuration=runs["setting"])).set_index(["configuration", "trial"])
counts = {s: [int(by.at[(s, k), "solved"]) for k in (2, 3, 4, 5)] for s in ("all samples", "SoD")}
print(f"runs: {len(runs)} (missing: {', '.join(missing) or 'none'})\n")
for setting, group in runs.groupby("setting"):
    open_runs = group[group["first_success"].isna() & (group["last_trial"] < 5)]
    names = ", ".join(Path(r).name for r in open_runs["run"]) or "none"
    print(f"{setting}: solved by T2/T3/T4/T5 {' / '.join(map(str, counts[setting]))} of "
          f"{len(group)} (unfinished without success: {names})")
print()
print(solved_by_trial(runs.drop(columns="setting")).to_string(index=False))
print()
print(paired_markdown(runs.drop(columns="setting")))
if missing or any(runs["first_success"].isna() & (runs["last_trial"] < 5)):
    print("rule: not decided (runs missing or unfinished)")
    sys.exit(0)
no_worse = all(s >= f - 1 for s, f in zip(counts["SoD"], counts["all samples"]))
print("rule:", "the SoD learns no worse on these seeds" if no_worse else "the SoD learns worse")
