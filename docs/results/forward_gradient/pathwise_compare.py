"""Where two searches from the same checkpoint part (pathwise.sh's trial-3 traces, code
before and after): the particles' cost per step and the first step at which the two differ
by more than a relative 1e-6, 1e-3, 1e-2.

    python docs/results/forward_gradient/pathwise_compare.py
"""

from pathlib import Path

import numpy as np
import pandas as pd

HERE = Path(__file__).resolve().parent / "pathwise"
new = pd.read_csv(HERE / "new_trial_03.csv")["cost"].to_numpy()
old = pd.read_csv(HERE / "old_trial_03.csv")["cost"].to_numpy()
n = min(len(new), len(old))
relative = np.abs(new[:n] - old[:n]) / np.abs(old[:n])
print(f"steps: new {len(new)}, old {len(old)}")
for step in (0, 1, 2, 4, 8, 10, 50, 100, 400):
    print(f"step {step}: new {new[step]:.10g} old {old[step]:.10g} relative {relative[step]:.1e}")
for threshold in (1e-6, 1e-3, 1e-2):
    print(f"first step with relative difference > {threshold:g}: {int(np.argmax(relative > threshold))}")
