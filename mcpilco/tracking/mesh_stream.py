"""Rerun recording of mesh predictions (the CGPDM's cloth, thesis Figs. 6.3–6.4).

An observer for rollouts whose states are the points of a square mesh (x₁ y₁ z₁ x₂ …):
kind ``cloth`` carries the true mesh as states and the predicted mesh as measurements;
kind ``latent`` carries the predicted latent trajectory as states; kinds ``cloth_<name>``
(generated data sets) carry true meshes only, drawn on ``cloth_<name>/seq_k``. Entities, per
sequence k:
``cloth/seq_k/true`` and ``cloth/seq_k/predicted`` (points and grid lines on the ``time``
timeline, seconds), ``cloth/seq_k/error`` (mean point distance, m), ``latent/seq_k/path``
(the whole latent curve) and ``latent/seq_k/state`` (the current latent state).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from mcpilco.errors import ConfigError
from mcpilco.tracking.base import TrialObserver
from mcpilco.trajectory import Trajectory

COLORS = {"true": (40, 110, 220), "predicted": (220, 50, 40)}


def grid_lines(points: np.ndarray) -> list[np.ndarray]:
    """Rows and columns of a square mesh ``[G·G, 3]`` as line strips."""
    side = int(round(np.sqrt(len(points))))
    if side * side != len(points):
        raise ConfigError(f"a mesh of {len(points)} points is not square")
    grid = points.reshape(side, side, 3)
    return [grid[i] for i in range(side)] + [grid[:, j] for j in range(side)]


class MeshRerunStreamer(TrialObserver):
    """Writes ``filename`` in ``run_dir`` (``mode=save``) or streams to a viewer at ``url``
    (``mode=connect``, localhost by default)."""

    def __init__(
        self,
        run_dir: str | os.PathLike[str],
        mode: str = "save",
        filename: str = "recording.rrd",
        url: str = "rerun+http://127.0.0.1:9876/proxy",
    ) -> None:
        if mode not in ("save", "connect"):
            raise ConfigError(f"tracking.rerun must be off, save or connect, got {mode!r}")
        self.path = Path(run_dir) / filename
        self.recording = rr.RecordingStream("mcpilco", recording_id=str(Path(run_dir).resolve()))
        if mode == "save":
            self.recording.save(self.path)
        else:
            self.recording.connect_grpc(url)
        self._sequences: list[int] = []

    def run_started(self, metadata: Mapping[str, str], resumed_after: int) -> None:
        text = metadata.get("config", "")
        self.recording.log(
            "run/config", rr.TextDocument(text, media_type="text/markdown"), static=True
        )

    def _mesh(self, entity: str, time_s: float, flat: np.ndarray, which: str) -> None:
        points = flat.reshape(-1, 3)
        self.recording.set_time("time", duration=time_s)
        self.recording.log(entity, rr.Points3D(points, colors=COLORS[which], radii=0.003))
        self.recording.log(
            f"{entity}/mesh", rr.LineStrips3D(grid_lines(points), colors=COLORS[which])
        )

    def rollout(
        self,
        trial: int,
        trajectory: Trajectory,
        costs: np.ndarray,
        eval_costs: np.ndarray,
        kind: str | None = None,
    ) -> None:
        times = trajectory.times
        if kind == "cloth":
            for t, time_s in enumerate(times):
                self._mesh(f"cloth/seq_{trial}/true", time_s, trajectory.states[t], "true")
                self._mesh(
                    f"cloth/seq_{trial}/predicted", time_s, trajectory.measurements[t], "predicted"
                )
            self.recording.send_columns(
                f"cloth/seq_{trial}/error",
                indexes=[rr.TimeColumn("time", duration=times)],
                columns=rr.Scalars.columns(scalars=np.asarray(costs, dtype=np.float64)),
            )
            self._sequences.append(trial)
        elif kind is not None and kind.startswith("cloth_"):  # a generated data set
            for t, time_s in enumerate(times):
                self._mesh(f"{kind}/seq_{trial}", time_s, trajectory.states[t], "true")
        elif kind == "latent":
            path = trajectory.states
            self.recording.log(f"latent/seq_{trial}/path", rr.LineStrips3D([path]), static=True)
            for t, time_s in enumerate(times):
                self.recording.set_time("time", duration=time_s)
                self.recording.log(
                    f"latent/seq_{trial}/state", rr.Points3D(path[t : t + 1], radii=0.01)
                )

    def blueprint(self) -> rrb.Blueprint:
        """The first sequence's cloth (true and predicted) and all latent paths in 3-D, the
        prediction errors below."""
        first = self._sequences[0] if self._sequences else 0
        return rrb.Blueprint(
            rrb.Vertical(
                rrb.Horizontal(
                    rrb.Spatial3DView(origin=f"cloth/seq_{first}", name="cloth: true / CGPDM"),
                    rrb.Spatial3DView(origin="latent", name="latent trajectories"),
                ),
                rrb.TimeSeriesView(origin="cloth", name="mean point distance (m)"),
                row_shares=[3, 1],
            ),
            collapse_panels=True,
        )

    def close(self) -> None:
        self.recording.send_blueprint(self.blueprint())
        self.recording.flush()
        self.recording.disconnect()
