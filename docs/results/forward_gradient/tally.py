"""The learning rule of this folder's README on its run directories: SE seeds 0-9 with the
forward-gradient code (se_seed_S here) against the float64 record of the same seeds
(../mixed_precision/recheck_2026-12-05/f64_se_seed_S): solved by trial 2..5, per seed which
solved first, and the verdict (stays the default if >= 6 solved by T4 and >= 8 by T5).

    PYTHONPATH=. python docs/results/forward_gradient/tally.py
"""

from __future__ import annotations

import sys
from pathlib import Path

from analysis.first_success import first_successes, paired_markdown, solved_by_trial
from analysis.report import load_sweep

HERE = Path(__file__).resolve().parent
RECORD = HERE.parent / "mixed_precision" / "recheck_2026-12-05"
new = [HERE / f"se_seed_{s}" for s in range(10)]
record = [RECORD / f"f64_se_seed_{s}" for s in range(10)]
missing = [d.name for d in new if not (d / "summary.csv").is_file()]
trials, _ = load_sweep([d for d in new + record if d.is_dir()])
runs = first_successes(trials)
runs["configuration"] = [
    "forward gradient" if Path(r).parent == HERE else "float64 record" for r in runs["run"]
]
table = solved_by_trial(runs).set_index(["configuration", "trial"])
for name in ("forward gradient", "float64 record"):
    counts = [int(table.at[(name, k), "solved"]) for k in (2, 3, 4, 5)]
    print(f"{name}: solved by T2/T3/T4/T5 {' / '.join(map(str, counts))}")
print()
print(paired_markdown(runs))
unfinished = runs["first_success"].isna() & (runs["last_trial"] < 5)
if missing or unfinished.any():
    print(f"verdict: not yet (missing {missing}, unfinished {list(runs.loc[unfinished, 'run'])})")
    sys.exit(0)
by4 = int(table.at[("forward gradient", 4), "solved"])
by5 = int(table.at[("forward gradient", 5), "solved"])
keep = by4 >= 6 and by5 >= 8
print(f"verdict: {by4} by T4, {by5} by T5 ->", "stays the default" if keep else "becomes opt-in")
