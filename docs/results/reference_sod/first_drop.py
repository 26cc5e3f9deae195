"""For each float64 run without reduction: how many samples the reference SoD (relative 0.5)
keeps of each trial's GP (the fit is the same as an SoD run's until the first dropped
sample, so the SoD run is that run up to the trial where it first drops one)."""
import sys
from pathlib import Path
import pandas as pd
from analysis.evaluate import load_trial
from mcpilco.gp.reduction import reduce_dataset

for run in sys.argv[1:]:
    summary = pd.read_csv(Path(run) / "summary.csv")
    success = summary.loc[summary.success.astype(bool) & (summary.trial > 0), "trial"]
    first = int(success.min()) if len(success) else None
    cells = []
    for trial in range(1, int(summary.trial.max()) + 1):
        _, experiment = load_trial(Path(run), trial)
        gp = experiment.components.model.gp
        n = gp.train_inputs.shape[0]
        kept = len(reduce_dataset(gp, 0.5, "relative"))
        cells.append(f"T{trial} {kept}/{n}")
        if kept < n:
            break
    print(Path(run).name, "first success", f"T{first}" if first else "—", "|", ", ".join(cells), flush=True)
