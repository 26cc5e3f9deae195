"""What another monitoring schedule would have decided on stored optimisation traces:
``python -m analysis.schedule_replay RUN_DIR... --set KEY=VALUE [--set ...] [--csv OUT]``.

The schedule (eq. 2.12–2.15) sees nothing but the cost Ĵ of each step, and until it first
lowers p_d and α_lr the optimisation does not depend on it. So a stored trace
(``optimization/trial_KK.csv``) replayed through the run's own ``optimizer.schedule``
must reproduce its recorded reductions (checked: a trace that does not, e.g. one cut into
horizon stages, is reported and skipped), and replayed through a changed one (``--set
window=100``, ``--set bias_correction=true``, keys of :class:`MonitoringSchedule`) it gives
the changed schedule's decisions **exactly** up to the first step where they differ from
the recorded ones. There the table says what the changed schedule did:

- ``reduces``: it lowers p_d and α_lr at that step, before the recorded schedule did;
- ``holds``: the recorded schedule reduced there and the changed one does not; its own
  reduction then comes no earlier than ``earliest_next`` (the step at which its count of
  consecutive steps with |s| < σ_s could first reach n_s);
- ``stops`` / ``continues``: the same for the stop (2.15);
- ``same``: identical decisions over the whole trace (the run would have been identical).

Beyond the divergence the costs would have differed, and nothing is claimed about them.
"""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import pandas as pd
import yaml
from omegaconf import OmegaConf

from mcpilco.optim import MonitoringSchedule


def parse_settings(pairs: Sequence[str]) -> dict[str, Any]:
    """``KEY=VALUE`` strings into schedule options; VALUE is read as YAML (``100``, ``true``).

    Raises:
        SystemExit: naming a malformed pair or a key the schedule does not have.
    """
    known = {f.name for f in dataclasses.fields(MonitoringSchedule) if f.init}
    settings: dict[str, Any] = {}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        if not sep or not key:
            raise SystemExit(f"--set expects KEY=VALUE, got {pair!r}")
        if key not in known:
            raise SystemExit(f"--set {key}: not a schedule key (one of {sorted(known)})")
        settings[key] = yaml.safe_load(value)
    return settings


def replay(costs: Sequence[float], options: dict[str, Any]) -> list[tuple[bool, bool, int]]:
    """(reduced, stop, steps counted below σ_s after the update) for each cost, in order."""
    schedule = MonitoringSchedule(**options)
    decisions = []
    for cost in costs:
        event = schedule.update(cost)
        decisions.append((event.reduced, event.stop, schedule.steps_below))
    return decisions


def compare(
    before: Sequence[tuple[bool, bool, int]], after: Sequence[tuple[bool, bool, int]], window: int
) -> dict[str, object]:
    """Where the changed schedule's decisions (``after``, its n_s ``window``) first differ
    from the recorded schedule's (``before``), both from :func:`replay`."""
    for step, (old, new) in enumerate(zip(before, after, strict=True)):
        if old[:2] == new[:2]:
            continue
        if new[0] != old[0]:
            what = "reduces" if new[0] else "holds"
        else:
            what = "stops" if new[1] else "continues"
        earliest = step + window - new[2] if what == "holds" else None
        return {"diverges_at": step, "changed_schedule": what, "earliest_next": earliest}
    return {"diverges_at": None, "changed_schedule": "same", "earliest_next": None}


def trace_rows(run: Path, changes: dict[str, Any]) -> list[dict[str, object]]:
    """One record per optimisation trace of one run directory."""
    config = OmegaConf.to_container(OmegaConf.load(run / "config.yaml"), resolve=True)
    schedule = config.get("optimizer", {}).get("schedule")  # type: ignore[union-attr]
    if not isinstance(schedule, dict):
        raise SystemExit(f"{run / 'config.yaml'}: no optimizer.schedule (not an MC-PILCO run?)")
    recorded = dict(schedule)
    changed = recorded | changes
    window = MonitoringSchedule(**changed).window  # validates the changed schedule too
    rows = []
    for trace_file in sorted((run / "optimization").glob("trial_*.csv")):
        trace = pd.read_csv(trace_file)
        if trace.empty:
            continue
        missing = {"cost", "learning_rate"} - set(trace.columns)
        if missing:
            raise SystemExit(f"{trace_file}: no column {sorted(missing)} (not a Ĵ trace?)")
        costs = trace["cost"].tolist()
        reductions = trace.index[trace["learning_rate"].diff().fillna(0.0) < 0].tolist()
        row: dict[str, object] = {
            "run": str(run),
            "trial": int(trace_file.stem.removeprefix("trial_")),
            "steps": len(trace),
            "recorded_reductions": " ".join(str(r) for r in reductions),
        }
        before = replay(costs, recorded)
        replayed = [j for j, (reduced, _, _) in enumerate(before) if reduced]
        stops = [j for j, (_, stop, _) in enumerate(before) if stop]
        # a horizon curriculum starts a fresh schedule per stage (older traces: no column)
        staged = "horizon" in trace and trace["horizon"].nunique() > 1
        if staged or replayed != reductions or stops[:1] not in ([], [len(costs) - 1]):
            row["changed_schedule"] = "not reproduced"
        else:
            row.update(compare(before, replay(costs, changed), window))
        rows.append(row)
    return rows


def load(paths: Iterable[Path], changes: dict[str, Any]) -> pd.DataFrame:
    """Every run directory (one holding ``optimization/``) under the given paths."""
    runs = sorted({p.parent for path in paths for p in Path(path).rglob("optimization")})
    return pd.DataFrame([row for run in runs for row in trace_rows(run, changes)])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("runs", nargs="+", type=Path, help="run directories or folders of them")
    parser.add_argument("--set", action="append", default=[], help="KEY=VALUE (repeatable)")
    parser.add_argument("--csv", type=Path, help="write the per-trace table here")
    args = parser.parse_args()
    changes = parse_settings(args.set)
    table = load(args.runs, changes)
    if table.empty:
        raise SystemExit(f"no optimisation traces under {[str(p) for p in args.runs]}")
    with pd.option_context("display.width", 200, "display.max_rows", 500):
        print(table.to_string(index=False))  # noqa: T201
        print(table["changed_schedule"].value_counts().to_string())  # noqa: T201
    if args.csv:
        table.to_csv(args.csv, index=False)


if __name__ == "__main__":
    main()
