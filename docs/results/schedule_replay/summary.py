"""Counts over the replays in this folder (run by replay.sh, from the repository root)."""

from pathlib import Path

import pandas as pd

here = Path(__file__).parent
for name in sorted(p.stem for p in here.glob("*.csv")):
    table = pd.read_csv(here / f"{name}.csv")
    first = table["recorded_reductions"].astype(str).str.split().str[0].astype(float)
    window = int(first.min())  # the recorded n_s: the earliest a first reduction can come
    warm = table[first == window]
    rest = table[first != window]
    counts = table["changed_schedule"].value_counts().to_dict()
    print(f"## {name}: {len(table)} traces, {counts}")  # noqa: T201
    for label, part in (("first reduction at step n_s", warm), ("first reduction later", rest)):
        reduces = part[part["changed_schedule"] == "reduces"]["diverges_at"].astype(int)
        holds = part[part["changed_schedule"] == "holds"]
        delay = (holds["earliest_next"] - holds["diverges_at"]).astype(int)
        line = f"  {label} ({len(part)}): reduces earlier {len(reduces)}"
        if len(reduces):
            line += f" (at steps {reduces.min()}-{reduces.max()}, median {reduces.median():g})"
        line += f"; holds {len(holds)}"
        if len(holds):
            line += (
                f" (its next reduction no earlier than +{delay.min()} to +{delay.max()} steps "
                f"later, median +{delay.median():g}; +{delay.max()} in "
                f"{int((delay == delay.max()).sum())})"
            )
        print(line + f"; same {int((part['changed_schedule'] == 'same').sum())}")  # noqa: T201
