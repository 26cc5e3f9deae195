"""Time of trial 1 at the thesis's settings: ``make bench-trial`` (or
``python -m runners.bench_trial [--threads 1] [--seed 0] [--setting float64 mixed]``).

Runs the real runner (``runners.train``, default cart-pole: SE speed-integration model,
M = 400, n_b = 200, the full monitoring schedule of trial 1) for one learning trial in a
temporary run directory, once per setting, one after another, and prints the process's wall
time and the trial's phases from its ``summary.csv``: GP fit, policy optimisation (steps
and ms per step), the step after which Ĵ stayed within 1 % of its final value
(``steps_to_final``), the system rollout and the rest (process start, imports, compiling,
exploration, storage). Kept out of ``make bench``: it takes minutes per setting.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd

SETTINGS = {
    "float64": ["dtype=float64", "rollout_dtype=null"],
    "float32": ["dtype=float32", "rollout_dtype=null"],
    "mixed": ["dtype=float64", "rollout_dtype=float32"],
}
"""Named settings and their overrides."""


def trial_one(overrides: list[str], threads: int, seed: int) -> dict[str, float]:
    """Wall time and phases (seconds) of a one-trial run with ``overrides``."""
    with tempfile.TemporaryDirectory() as folder:
        command = [
            sys.executable,
            "-m",
            "runners.train",
            "num_trials=1",
            f"seed={seed}",
            f"threads={threads}",
            "tracking.mcap=null",
            f"hydra.run.dir={folder}",
            *overrides,
        ]
        start = time.perf_counter()
        subprocess.run(command, check=True, capture_output=True, cwd=Path(__file__).parent.parent)
        wall = time.perf_counter() - start
        row = pd.read_csv(Path(folder) / "summary.csv").set_index("trial").loc[1]
    phases = {
        "wall": wall,
        "fit": float(row["fit_seconds"]),
        "optimisation": float(row["optimization_seconds"]),
        "steps": float(row["optimization_steps"]),
        "steps_to_final": float(row.get("steps_to_final", float("nan"))),
        "rollout": float(row["rollout_seconds"]),
        "eval_cost": float(row["eval_cost"]),
    }
    phases["rest"] = wall - phases["fit"] - phases["optimisation"] - phases["rollout"]
    return phases


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--threads", type=int, default=1, help="torch threads of the run")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--setting", nargs="+", default=["float64", "mixed"], choices=sorted(SETTINGS)
    )
    args = parser.parse_args()
    print(f"trial 1, thesis settings, seed {args.seed}, {args.threads} thread(s):")  # noqa: T201
    for name in args.setting:
        p = trial_one(SETTINGS[name], args.threads, args.seed)
        print(  # noqa: T201
            f"  {name}: wall {p['wall']:.1f} s = fit {p['fit']:.1f} s + optimisation "
            f"{p['optimisation']:.1f} s ({p['steps']:.0f} steps, "
            f"{1e3 * p['optimisation'] / p['steps']:.1f} ms/step; within 1 % of the final Ĵ "
            f"after {p['steps_to_final']:.0f}) + system rollout {p['rollout']:.1f} s + rest "
            f"{p['rest']:.1f} s; evaluation cost {p['eval_cost']:.2f}"
        )


if __name__ == "__main__":
    main()
