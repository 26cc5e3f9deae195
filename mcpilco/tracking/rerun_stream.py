"""Stream particle predictions, rollouts and optimisation curves to Rerun.

Every call logs whole arrays with ``rr.send_columns`` (one call per entity and trial, never
one scalar per call). Entities, per trial k and state component i:
``trial_k/particles/x{i}`` (M' particle values per time step), ``trial_k/mean/x{i}``,
``trial_k/real/x{i}`` (the system's true state), ``trial_k/cost`` (real) and
``trial_k/particle_cost`` (mean over particles), all on the ``time`` timeline (seconds);
``optimization/{cost,dropout,learning_rate,signal,horizon}`` on the ``optimization_step`` and
``trial`` timelines.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from mcpilco.errors import ConfigError
from mcpilco.tracking.base import TrialObserver
from mcpilco.tracking.schema import TRACE_KEYS
from mcpilco.trajectory import Trajectory

LOCAL_VIEWER = "rerun+http://127.0.0.1:9876/proxy"


class RerunStreamer(TrialObserver):
    """A Rerun recording of the run.

    Args:
        run_dir: the run directory.
        mode: ``save`` writes ``filename`` into the run directory; ``connect`` streams to
            a running viewer at ``url`` (localhost by default).
        max_particles: particles drawn per trial (the first ones; mean uses all).
        sketch: the system's 2-D drawing of states (``MechanicalSystem.sketch``), drawn
            on ``trial_k/system`` along the ``time`` timeline.
    """

    wants_particles = True

    def __init__(
        self,
        run_dir: str | os.PathLike[str],
        mode: str = "save",
        filename: str = "recording.rrd",
        url: str = LOCAL_VIEWER,
        max_particles: int = 100,
        sketch: Callable[[np.ndarray], np.ndarray | None] | None = None,
    ) -> None:
        if mode not in ("save", "connect"):
            raise ConfigError(f"tracking.rerun.mode must be save or connect, got {mode!r}")
        if max_particles < 1:
            raise ConfigError(f"tracking.rerun.max_particles must be >= 1, got {max_particles}")
        self.path = Path(run_dir) / filename
        self.max_particles = max_particles
        self.recording = rr.RecordingStream("mcpilco", recording_id=str(Path(run_dir).resolve()))
        if mode == "save":
            self.recording.save(self.path)
        else:
            self.recording.connect_grpc(url)
        self._optimization_steps = 0
        self.sketch = sketch
        self._trials: list[int] = []
        self._state_dim = 0

    def _scalars(self, entity: str, times: np.ndarray, values: np.ndarray) -> None:
        """``values [T]`` or ``[T, K]`` (K series) against ``times [T]`` seconds."""
        columns = rr.Scalars.columns(scalars=np.ascontiguousarray(values, dtype=np.float64).ravel())
        if values.ndim == 2:
            columns = columns.partition([values.shape[1]] * values.shape[0])
        self.recording.send_columns(
            entity, indexes=[rr.TimeColumn("time", duration=times)], columns=columns
        )

    def run_started(self, metadata: Mapping[str, str], resumed_after: int) -> None:
        text = metadata.get("config", "")
        self.recording.log(
            "run/config", rr.TextDocument(text, media_type="text/markdown"), static=True
        )

    def particles_predicted(
        self, trial: int, states: np.ndarray, costs: np.ndarray, dt: float
    ) -> None:
        times = np.arange(states.shape[0]) * dt
        shown = states[:, : self.max_particles]
        for i in range(states.shape[2]):
            self._scalars(f"trial_{trial}/particles/x{i}", times, shown[:, :, i])
            self._scalars(f"trial_{trial}/mean/x{i}", times, states[:, :, i].mean(1))
        self._scalars(f"trial_{trial}/particle_cost", times, costs.mean(1))

    def rollout(
        self,
        trial: int,
        trajectory: Trajectory,
        costs: np.ndarray,
        eval_costs: np.ndarray,
        kind: str | None = None,
    ) -> None:
        times = trajectory.times
        for i in range(trajectory.states.shape[1]):
            self._scalars(f"trial_{trial}/real/x{i}", times, trajectory.states[:, i])
        self._scalars(f"trial_{trial}/cost", times, costs)

    def blueprint(self) -> rrb.Blueprint:
        """Latest trial: particles, mean and real trajectory per state component, the system
        drawing, costs; optimisation curves below; earlier trials in tabs."""
        tabs = []
        for trial in reversed(self._trials):
            plots = [
                rrb.TimeSeriesView(
                    name=f"x{i}",
                    origin=f"/trial_{trial}",
                    contents=[f"+ particles/x{i}/**", f"+ mean/x{i}", f"+ real/x{i}"],
                )
                for i in range(self._state_dim)
            ]
            side = [
                rrb.Spatial2DView(name="system", origin=f"/trial_{trial}/system"),
                rrb.TimeSeriesView(
                    name="cost", origin=f"/trial_{trial}", contents=["+ cost", "+ particle_cost"]
                ),
            ]
            tabs.append(
                rrb.Horizontal(rrb.Grid(*plots), rrb.Vertical(*side), name=f"trial {trial}")
            )
        optimization = rrb.TimeSeriesView(name="optimisation", origin="/optimization")
        calibration = rrb.TimeSeriesView(name="calibration per trial", origin="/calibration")
        return rrb.Blueprint(
            rrb.Vertical(
                rrb.Tabs(*tabs),
                rrb.Horizontal(optimization, calibration, column_shares=[2, 1]),
                row_shares=[3, 1],
            )
        )

    def optimized(self, trial: int, trace: Mapping[str, list[float]]) -> None:
        steps = np.arange(len(trace["cost"])) + self._optimization_steps
        self._optimization_steps += len(steps)
        index = [
            rr.TimeColumn("optimization_step", sequence=steps),
            rr.TimeColumn("trial", sequence=np.full(len(steps), trial)),
        ]
        for name in TRACE_KEYS:
            self.recording.send_columns(
                f"optimization/{name}",
                indexes=index,
                columns=rr.Scalars.columns(scalars=np.asarray(trace[name], dtype=np.float64)),
            )

    def trial_finished(self, trial: int, summary: Mapping[str, Any]) -> None:
        """The trial's calibration figures (learning trials) on the ``trial`` timeline."""
        self.recording.set_time("trial", sequence=trial)
        for group in ("coverage", "nll"):
            keys = [k for k in summary if k.startswith(f"{group}_") and k != f"{group}_mean"]
            for i, key in enumerate(keys):  # components in state order: x0, x1, ...
                self.recording.log(f"calibration/{group}/x{i}", rr.Scalars(float(summary[key])))
            if f"{group}_mean" in summary:
                value = float(summary[f"{group}_mean"])
                self.recording.log(f"calibration/{group}/mean", rr.Scalars(value))
        self.recording.flush()

    def close(self) -> None:
        self.recording.flush()
        self.recording.disconnect()
