"""Rebuild a run's Rerun recording from its MCAP log alone (nothing is re-run).

    python -m runners.replay RUN_DIR [--trial K] [--save OUT.rrd | --connect [URL]]

Without ``--save``/``--connect`` it writes ``RUN_DIR/replay.rrd``.
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from mcpilco.safe_config import saved_system
from mcpilco.tracking import RerunStreamer, read_run_log
from mcpilco.tracking.reader import RunLog
from mcpilco.tracking.rerun_stream import LOCAL_VIEWER
from mcpilco.tracking.schema import TRACE_KEYS
from mcpilco.trajectory import Trajectory

log = logging.getLogger("mcpilco.replay")


def columns(frame, prefix: str) -> np.ndarray:  # type: ignore[no-untyped-def]
    names = sorted(
        (c for c in frame.columns if c.startswith(prefix + "_")),
        key=lambda c: int(c.rsplit("_", 1)[1]),
    )
    return frame[names].to_numpy(dtype=np.float64)


def complete_trials(run_log: RunLog) -> list[int]:
    """Trials whose summary message and whole rollout (steps 0, 1, ..., T) are in the log;
    a trial partly lost to a damaged record is named in a warning and left out."""
    logged = sorted(run_log.trials["trial"].tolist()) if len(run_log.trials) else []
    complete = []
    for trial in logged:
        steps = run_log.rollout(trial)["step"].tolist() if len(run_log.rollouts) else []
        if len(steps) >= 2 and steps == list(range(len(steps))):
            complete.append(trial)
        else:
            log.warning("trial %d: its rollout is incomplete in the log; not replayed", trial)
    return complete


def warn_unlogged(run_dir: Path, logged: list[int]) -> None:
    """Warn about trials the run directory's ``summary.csv`` lists as finished that the
    log lacks (a damaged log, or an older run killed between its summary and its log)."""
    summary = run_dir / "summary.csv" if run_dir.is_dir() else None
    if summary is None or not summary.is_file():
        return
    try:
        finished = pd.read_csv(summary)["trial"].astype(int).tolist()
    except (ValueError, KeyError, pd.errors.ParserError) as error:
        log.warning("%s is unreadable (%s)", summary, type(error).__name__)
        return
    missing = sorted(set(finished) - set(logged))
    if missing:
        log.warning(
            "%s are finished (summary.csv) but not whole in the log; their data are in %s",
            missing,
            run_dir,
        )


def replay(run_log: RunLog, streamer: RerunStreamer, trials: list[int]) -> None:
    """Feed the logged trials to ``streamer`` through the same hooks a live run uses."""
    streamer.run_started(run_log.metadata[0] if run_log.metadata else {}, -1)
    for trial in trials:
        trace = (
            run_log.optimization[run_log.optimization["trial"] == trial]
            if len(run_log.optimization)
            else None
        )
        if trace is not None and len(trace):
            streamer.optimized(
                trial,
                {k: trace[k].tolist() for k in TRACE_KEYS},
            )
        if trial in run_log.particles:
            particles = run_log.particles[trial]
            dt = float(run_log.rollout(trial)["time"].diff().iloc[1])
            streamer.particles_predicted(
                trial, particles["states"], particles["cost_mean"][:, None], dt
            )
        rollout = run_log.rollout(trial)
        states = columns(rollout, "state")
        actions = columns(rollout, "action")[:-1]
        dt = float(rollout["time"].iloc[1] - rollout["time"].iloc[0])
        trajectory = Trajectory(states, columns(rollout, "measurement"), actions, dt)
        streamer.rollout(
            trial, trajectory, rollout["cost"].to_numpy(), rollout["eval_cost"].to_numpy()
        )
        streamer.trial_finished(trial, calibration_of(run_log, trial))
    streamer.close()


def calibration_of(run_log: RunLog, trial: int) -> dict[str, float]:
    """The trial's logged calibration figures (``coverage_<i>``, ``nll_<i>``, the means),
    empty for the exploration trial and for logs written before they existed."""
    if not len(run_log.trials) or "coverage_0" not in run_log.trials.columns:
        return {}
    row = run_log.trials[run_log.trials["trial"] == trial]
    if row.empty or row["coverage_0"].isna().all():
        return {}
    record = row.iloc[0]
    keys = [k for k in run_log.trials.columns if k.startswith(("coverage_", "nll_"))]
    return {k: float(record[k]) for k in keys if pd.notna(record[k])}


def replay_meshes(run_log: RunLog, args: argparse.Namespace) -> int:
    """A cloth run (``runners.cgpdm``): every whole rollout — test sequences (true and
    predicted cloth), latent trajectories, generated data sets — through the hooks of the
    live mesh recording."""
    from mcpilco.tracking.mesh_stream import MeshRerunStreamer

    if args.connect:
        streamer = MeshRerunStreamer(args.run_dir, mode="connect", url=args.connect)
    else:
        out = args.save or args.run_dir / "replay.rrd"
        streamer = MeshRerunStreamer(out.parent, mode="save", filename=out.name)
    streamer.run_started(run_log.metadata[0] if run_log.metadata else {}, -1)
    rollouts = run_log.rollouts
    if args.trial:
        rollouts = rollouts[rollouts["trial"].isin(args.trial)]
    replayed, skipped = set(), set()
    for (trial, kind), rows in rollouts.groupby(["trial", "kind"], sort=True):
        part = rows.dropna(axis=1, how="all")
        if len(part) < 2 or part["step"].tolist() != list(range(len(part))):
            skipped.add(int(trial))
            continue
        dt = float(part["time"].iloc[1] - part["time"].iloc[0])
        trajectory = Trajectory(
            columns(part, "state"), columns(part, "measurement"),
            columns(part, "action")[:-1], dt,
        )  # fmt: skip
        cost = part["cost"].to_numpy()
        streamer.rollout(int(trial), trajectory, cost, cost, kind=str(kind))
        replayed.add(int(trial))
    streamer.close()
    whole = sorted(replayed - skipped)
    if skipped:
        log.warning("sequences %s are not whole in the log; not replayed", sorted(skipped))
    if "cloth" in set(rollouts["kind"]):  # a cgpdm run: its summary lists the test sequences
        warn_unlogged(args.run_dir, whole)
    if not whole:
        log.error("%s holds no whole sequence in its log: nothing replayed", args.run_dir)
        return 2
    log.info("replayed sequences %s", whole)
    if not args.connect:
        log.info("wrote %s", args.save or args.run_dir / "replay.rrd")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("run_dir", type=Path)
    parser.add_argument("--trial", type=int, action="append", help="only these trials")
    target = parser.add_mutually_exclusive_group()
    target.add_argument("--save", type=Path, help="write the recording here")
    target.add_argument("--connect", nargs="?", const=LOCAL_VIEWER, help="stream to a viewer")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(message)s")
    try:
        run_log = read_run_log(args.run_dir)
    except (FileNotFoundError, ValueError) as error:
        log.error("%s", error)
        return 2
    if run_log.truncated:
        log.warning("the log ends early (killed run): replaying the trials it holds whole")
    if len(run_log.rollouts) and any(str(k).startswith("cloth") for k in run_log.rollouts["kind"]):
        return replay_meshes(run_log, args)
    available = complete_trials(run_log)
    warn_unlogged(args.run_dir, available)
    if not available:
        log.error("%s holds no whole trial in its log: nothing to replay", args.run_dir)
        return 2
    trials = args.trial or available
    missing = sorted(set(trials) - set(available))
    if missing:
        log.error("trials %s are not in %s (it holds %s)", missing, args.run_dir, available)
        return 2
    sketch, names = None, ()
    if run_log.metadata and "config" in run_log.metadata[0]:
        # the logged system, for its drawing; checked first (see mcpilco.safe_config), and
        # a plug-in that is not importable here only costs the drawing
        system = saved_system(
            run_log.metadata[0]["config"],
            f"{args.run_dir} (MCAP metadata)",
            untrusted=args.run_dir if args.run_dir.is_dir() else args.run_dir.parent,
        )
        if system is not None:
            sketch, names = system.sketch, system.state_names
    if args.connect:
        streamer = RerunStreamer(
            args.run_dir, mode="connect", url=args.connect, sketch=sketch, state_names=names
        )
    else:
        out = args.save or args.run_dir / "replay.rrd"
        streamer = RerunStreamer(
            out.parent, mode="save", filename=out.name, sketch=sketch, state_names=names,
            new_part=False,
        )  # fmt: skip
    replay(run_log, streamer, trials)
    log.info("replayed trials %s", trials)
    if not args.connect:
        log.info("wrote %s", args.save or args.run_dir / "replay.rrd")
    return 0


if __name__ == "__main__":
    sys.exit(main())
