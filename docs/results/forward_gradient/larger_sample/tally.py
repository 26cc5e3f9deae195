"""The paired larger sample (started in session 26): per seed, the first success with
model.gp.forward_gradient=true and =false on the same code (run directories
fg_{true,false}_se_seed_S here), solved by trial 2..5 per setting and the sign count.

    PYTHONPATH=. python docs/results/forward_gradient/larger_sample/tally.py
"""

from __future__ import annotations

from pathlib import Path

from analysis.first_success import first_successes, paired_markdown, solved_by_trial
from analysis.report import load_sweep

HERE = Path(__file__).resolve().parent
runs_dirs = sorted(d for d in HERE.glob("fg_*_seed_*") if (d / "summary.csv").is_file())
trials, _ = load_sweep(runs_dirs)
runs = first_successes(trials)
runs["configuration"] = [
    "forward_gradient=" + Path(r).name.split("_")[1] for r in runs["run"]
]
table = solved_by_trial(runs)
print(table.to_string(index=False))
print()
print(paired_markdown(runs, min_seeds=1))
unfinished = runs[runs["first_success"].isna() & (runs["last_trial"] < 5)]
print("unfinished without success:", ", ".join(Path(r).name for r in unfinished["run"]) or "none")
