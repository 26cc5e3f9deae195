"""Stream particle predictions, rollouts and optimisation curves to Rerun.

Every call logs whole arrays with ``rr.send_columns`` (one call per entity and trial, never
one scalar per call). Entities, per trial k and state component i:
``trial_k/particles/x{i}`` (M' particle values per time step), ``trial_k/mean/x{i}``,
``trial_k/real/x{i}`` (the system's true state), ``trial_k/cost`` (real) and
``trial_k/particle_cost`` (mean over particles) and ``trial_k/system`` (the system's 2-D
drawing, when it has one), all on the ``time`` timeline (seconds);
``optimization/{cost,dropout,learning_rate,signal,horizon}`` on the ``optimization_step`` and
``trial`` timelines; ``calibration/{coverage,nll}/x{i}`` on ``trial``; ``run/config`` (static).

Every recording carries its blueprint (:func:`run_blueprint`), re-sent after each trial: a tab
per trial (newest first) with particles, their mean and the real rollout in one plot per state
component, the drawing and the costs; a tab with the optimisation and calibration curves (on
their own timelines: Rerun's views follow the time panel's timeline, so these show once
``optimization_step`` or ``trial`` is picked there); the run's config as text; the time panel
on ``time``.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
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

# Colour (RGBA, on the viewer's dark background), width and legend name of each series kind.
STYLES: dict[str, tuple[tuple[int, int, int, int], float, str]] = {
    "particles": ((150, 150, 150, 110), 0.75, "particle"),
    "mean": ((70, 150, 255, 255), 2.5, "particle mean"),
    "real": ((255, 165, 40, 255), 2.5, "system"),
    "cost": ((255, 165, 40, 255), 2.0, "system"),
    "particle_cost": ((70, 150, 255, 255), 2.0, "particle mean"),
}
KEY = "grey: particles, blue: their mean, orange: the system"


class RerunStreamer(TrialObserver):
    """A Rerun recording of the run.

    Args:
        run_dir: the run directory.
        mode: ``save`` writes ``filename`` into the run directory; ``connect`` streams to
            a running viewer at ``url`` (localhost by default).
        max_particles: particles drawn per trial (the first ones; mean uses all).
        sketch: the system's 2-D drawing of states (``MechanicalSystem.sketch``), drawn
            on ``trial_k/system`` along the ``time`` timeline.
        state_names: the state components' names (``MechanicalSystem.state_names``), for
            the plots' titles; ``x{i}`` alone where missing.
        new_part: where ``filename`` exists (a resumed run), write ``<stem>.<k>.rrd`` next
            to it rather than overwrite it (:func:`free_part`); a replay overwrites.
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
        state_names: Sequence[str] = (),
        new_part: bool = True,
    ) -> None:
        if mode not in ("save", "connect"):
            raise ConfigError(f"tracking.rerun.mode must be save or connect, got {mode!r}")
        if max_particles < 1:
            raise ConfigError(f"tracking.rerun.max_particles must be >= 1, got {max_particles}")
        self.path = Path(run_dir) / filename
        if mode == "save" and new_part:
            self.path = free_part(self.path)
        self.max_particles = max_particles
        self.recording = rr.RecordingStream("mcpilco", recording_id=str(Path(run_dir).resolve()))
        if mode == "save":
            self.recording.save(self.path)
        else:
            self.recording.connect_grpc(url)
        self._optimization_steps = 0
        self.sketch = sketch
        self.state_names = tuple(state_names)
        self._trials: list[int] = []
        self._state_dim = 0
        self._extent: dict[str, tuple[tuple[float, float], tuple[float, float]]] = {}

    def _scalars(
        self, entity: str, times: np.ndarray, values: np.ndarray, kind: str | None = None
    ) -> None:
        """``values [T]`` or ``[T, K]`` (K series) against ``times [T]`` seconds, drawn in
        the colour and width of ``kind`` (a key of ``STYLES``)."""
        if kind is not None:
            colour, width, name = STYLES[kind]
            series = 1 if values.ndim == 1 else values.shape[1]
            self.recording.log(
                entity,
                rr.SeriesLines(
                    colors=[colour] * series, widths=[width] * series, names=[name] * series
                ),
                static=True,
            )
        columns = rr.Scalars.columns(scalars=np.ascontiguousarray(values, dtype=np.float64).ravel())
        if values.ndim == 2:
            columns = columns.partition([values.shape[1]] * values.shape[0])
        self.recording.send_columns(
            entity, indexes=[rr.TimeColumn("time", duration=times)], columns=columns
        )

    def run_started(self, metadata: Mapping[str, str], resumed_after: int) -> None:
        """The config as text; a resumed run's blueprint also lists the trials 0..K of the
        earlier parts (their data are in the earlier files of the same recording)."""
        self._trials = list(range(resumed_after + 1))
        text = metadata.get("config", "")
        self.recording.log(
            "run/config", rr.TextDocument(text, media_type=rr.MediaType.TEXT), static=True
        )

    def particles_predicted(
        self, trial: int, states: np.ndarray, costs: np.ndarray, dt: float
    ) -> None:
        times = np.arange(states.shape[0]) * dt
        shown = states[:, : self.max_particles]
        for i in range(states.shape[2]):
            self._scalars(f"trial_{trial}/particles/x{i}", times, shown[:, :, i], "particles")
            self._scalars(f"trial_{trial}/mean/x{i}", times, states[:, :, i].mean(1), "mean")
        self._scalars(f"trial_{trial}/particle_cost", times, costs.mean(1), "particle_cost")

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
            self._scalars(f"trial_{trial}/real/x{i}", times, trajectory.states[:, i], "real")
        self._scalars(f"trial_{trial}/cost", times, costs, "cost")
        drawing = None if self.sketch is None else self.sketch(trajectory.states)
        if drawing is not None:
            self._segments(f"trial_{trial}/system", times, drawing)
        if trial not in self._trials:
            self._trials.append(trial)
        self._state_dim = trajectory.states.shape[1]
        self.recording.send_blueprint(self.blueprint(), make_active=True, make_default=True)

    def _segments(self, entity: str, times: np.ndarray, drawing: np.ndarray) -> None:
        """Line segments ``drawing [T, S, 2, 2]`` (metres, y up) per time ``times [T]``
        seconds, drawn 2 UI points wide; y is flipped for Rerun's 2-D views (y down)."""
        steps, segments = drawing.shape[:2]
        flipped = np.array(drawing, dtype=np.float32) * np.array([1.0, -1.0], dtype=np.float32)
        strips = flipped.reshape(steps * segments, 2, 2)
        columns = rr.LineStrips2D.columns(
            strips=list(strips), radii=np.full(steps * segments, -2.0, dtype=np.float32)
        ).partition([segments] * steps)  # negative radii: UI points
        self.recording.send_columns(
            entity, indexes=[rr.TimeColumn("time", duration=times)], columns=columns
        )
        low, high = flipped.reshape(-1, 2).min(0), flipped.reshape(-1, 2).max(0)
        margin = 0.1 * float((high - low).max()) + 1e-3
        self._extent[entity] = (
            (float(low[0]) - margin, float(high[0]) + margin),
            (float(low[1]) - margin, float(high[1]) + margin),
        )

    def blueprint(self) -> rrb.Blueprint:
        """The recording's layout for the trials seen so far (see :func:`run_blueprint`)."""
        names = [
            self.state_names[i] if i < len(self.state_names) else "" for i in range(self._state_dim)
        ]
        return run_blueprint(
            sorted(self._trials, reverse=True), names, self.sketch is not None, self._extent
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


def free_part(path: Path) -> Path:
    """``path`` if it does not exist, else the first free ``<stem>.<k>.rrd`` (k = 1, 2, ...):
    a resumed run adds a part to its recording (the same recording id: the viewer merges the
    parts it is given) instead of overwriting the trials already recorded."""
    part, k = path, 0
    while part.exists():
        k += 1
        part = path.with_name(f"{path.stem}.{k}{path.suffix}")
    return part


def recording_parts(run_dir: Path, filename: str = "recording.rrd") -> list[Path]:
    """The parts of a run's recording (``recording.rrd``, ``recording.1.rrd``, ...) in order."""
    first = run_dir / filename
    parts = []
    while (
        part := first if not parts else first.with_name(f"{first.stem}.{len(parts)}.rrd")
    ).exists():
        parts.append(part)
    return parts


def run_blueprint(
    trials: Sequence[int],
    state_names: Sequence[str],
    drawing: bool,
    extents: Mapping[str, tuple[tuple[float, float], tuple[float, float]]] | None = None,
) -> rrb.Blueprint:
    """A run's Rerun layout.

    Args:
        trials: the trials to show, one tab each, in this order (the first is shown).
        state_names: one per state component (``""`` where unnamed); a plot each.
        drawing: whether ``trial_k/system`` holds the system's drawing.
        extents: per drawing entity, the (x, y) ranges its view shows (the whole motion).
    """
    tabs: list[rrb.Container | rrb.View] = []
    for trial in trials:
        plots = [
            rrb.TimeSeriesView(
                name=f"x{i} {name}".strip() + ("" if i else f" ({KEY})"),
                plot_legend=rrb.PlotLegend(visible=False),
                origin=f"/trial_{trial}",
                contents=[f"+ $origin/{part}/x{i}/**" for part in ("particles", "mean", "real")],
            )
            for i, name in enumerate(state_names)
        ]
        cost = rrb.TimeSeriesView(
            name="cost (orange: system, blue: particle mean)",
            origin=f"/trial_{trial}",
            contents=["+ $origin/cost", "+ $origin/particle_cost"],
        )
        side = []
        if drawing:
            extent = (extents or {}).get(f"trial_{trial}/system")
            bounds = (
                None if extent is None else rrb.VisualBounds2D(x_range=extent[0], y_range=extent[1])
            )
            side.append(
                rrb.Spatial2DView(
                    name="system", origin=f"/trial_{trial}/system", visual_bounds=bounds
                )
            )
        tabs.append(
            rrb.Horizontal(
                rrb.Grid(*plots),
                rrb.Vertical(*side, cost),
                column_shares=[3, 1],
                name=f"trial {trial}",
            )  # fmt: skip
        )
    tabs.append(
        rrb.Vertical(
            rrb.TimeSeriesView(
                name="optimisation (timeline optimization_step)", origin="/optimization"
            ),
            rrb.TimeSeriesView(name="calibration (timeline trial)", origin="/calibration"),
            name="optimisation",
        )
    )
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Tabs(*tabs, active_tab=0),
            rrb.TextDocumentView(name="config", origin="/run/config"),
            column_shares=[4, 1],
        ),
        rrb.TimePanel(timeline="time", state="collapsed"),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        auto_views=False,
    )
