"""Every rollout, particle prediction, optimisation trace and GP fit of a run, in MCAP.

One file per run (``rollouts.mcap``), zstd-compressed chunks, protobuf messages (schemas
in :mod:`mcpilco.tracking.schema`), run metadata as an MCAP metadata record. The chunk in
progress is closed and flushed at the end of every trial, so a killed process leaves a
file whose finished trials read back whole (:func:`mcpilco.tracking.read_run_log`).
"""

from __future__ import annotations

import logging
import math
import os
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
from mcap.writer import CompressionType, Writer
from mcap_protobuf.schema import build_file_descriptor_set

from mcpilco.errors import ConfigError
from mcpilco.tracking import schema
from mcpilco.tracking.base import TrialObserver
from mcpilco.tracking.mcap_scan import ScanReport
from mcpilco.tracking.reader import iter_raw_messages
from mcpilco.trajectory import Trajectory

log = logging.getLogger(__name__)


class McapLogger(TrialObserver):
    """Writes the run's MCAP log.

    Args:
        run_dir: the run directory.
        filename: file name inside it.
        max_particles: particles per trial stored with their states (the first ones of the
            M simulated; mean and std always use all M); None keeps all.
    """

    wants_particles = True

    def __init__(
        self,
        run_dir: str | os.PathLike[str],
        filename: str = "rollouts.mcap",
        max_particles: int | None = None,
    ) -> None:
        if max_particles is not None and max_particles < 50:
            raise ConfigError(f"tracking.mcap.max_particles must be >= 50, got {max_particles}")
        self.path = Path(run_dir) / filename
        self.max_particles = max_particles
        self._writer: Writer | None = None
        self._stream: BinaryIO | None = None  # the file the writer writes (it never closes it)
        self._channels: dict[str, int] = {}
        self._last_time = 0

    # -------------------------------------------------------------------- writing
    def _open(self, resumed_after: int) -> None:
        kept: list[tuple[str, bytes]] = []
        if resumed_after >= 0 and self.path.exists():
            # Keep what the killed run wrote for the finished trials, exactly once (a trial
            # logged but not in the summary is dropped: the resumed run does it again).
            report, logged = ScanReport(), set()
            for topic, decoded, data in iter_raw_messages(self.path, report):
                if getattr(decoded, "trial", 0) <= resumed_after:
                    kept.append((topic, data))
                    if topic == "/trial":
                        logged.add(decoded.trial)
            missing = sorted(set(range(resumed_after + 1)) - logged)
            for problem in report.problems:
                log.warning("%s", problem)
            if missing:
                log.warning(
                    "%s lacks finished trials %s (a damaged log, or a run killed between its "
                    "summary and its log before mcpilco ordered them): they stay missing there; "
                    "their data are in the run directory",
                    self.path,
                    missing,
                )
        partial = self.path.with_name(f".{self.path.name}.partial")
        self._stream = open(partial, "wb")  # noqa: SIM115 (closed by close)
        self._writer = Writer(self._stream, compression=CompressionType.ZSTD)
        self._writer.start(profile="protobuf", library="mcpilco")
        for topic, message_class in schema.TOPICS.items():
            schema_id = self._writer.register_schema(
                name=message_class.DESCRIPTOR.full_name,
                encoding="protobuf",
                data=build_file_descriptor_set(message_class).SerializeToString(),
            )
            self._channels[topic] = self._writer.register_channel(
                topic=topic, message_encoding="protobuf", schema_id=schema_id
            )
        for topic, data in kept:
            self._write_bytes(topic, data)
        self._writer.flush()
        os.replace(partial, self.path)  # the open handle follows the file

    def _write_bytes(self, topic: str, data: bytes) -> None:
        assert self._writer is not None
        now = max(time.time_ns(), self._last_time + 1)
        self._last_time = now
        self._writer.add_message(self._channels[topic], log_time=now, data=data, publish_time=now)

    def _write(self, topic: str, message: Any) -> None:
        self._write_bytes(topic, message.SerializeToString())

    # ------------------------------------------------------------------ observer
    def run_started(self, metadata: Mapping[str, str], resumed_after: int) -> None:
        self._open(resumed_after)
        assert self._writer is not None
        self._writer.add_metadata("run", {**metadata, "resumed_after_trial": str(resumed_after)})

    def model_fitted(self, trial: int, hyperparameters: Mapping[str, list[float]]) -> None:
        for name, values in hyperparameters.items():
            flat = np.asarray(values, dtype=np.float64).ravel().tolist()
            self._write(
                "/gp/hyperparameters", schema.Hyperparameter(trial=trial, name=name, values=flat)
            )

    def optimized(self, trial: int, trace: Mapping[str, list[float]]) -> None:
        for step, values in enumerate(zip(*(trace[k] for k in schema.TRACE_KEYS), strict=True)):
            cost, dropout, learning_rate, signal, horizon = values
            self._write(
                "/optimization",
                schema.OptimizationStep(
                    trial=trial,
                    step=step,
                    cost=cost,
                    dropout=dropout,
                    learning_rate=learning_rate,
                    signal=signal,
                    horizon=int(horizon),
                ),
            )

    def particles_predicted(
        self, trial: int, states: np.ndarray, costs: np.ndarray, dt: float
    ) -> None:
        kept = states if self.max_particles is None else states[:, : self.max_particles]
        mean, std = states.mean(1), states.std(1)
        for step in range(states.shape[0]):
            self._write(
                "/particles",
                schema.ParticleSample(
                    trial=trial,
                    step=step,
                    time=step * dt,
                    num_particles=kept.shape[1],
                    state_dim=kept.shape[2],
                    states=kept[step].ravel().tolist(),
                    mean=mean[step].tolist(),
                    std=std[step].tolist(),
                    cost_mean=float(costs[step].mean()),
                ),
            )

    def rollout(
        self,
        trial: int,
        trajectory: Trajectory,
        costs: np.ndarray,
        eval_costs: np.ndarray,
        kind: str | None = None,
    ) -> None:
        if kind is None:
            kind = "exploration" if trial == 0 else "policy"
        for step, time_s in enumerate(trajectory.times):
            action = trajectory.actions[step] if step < trajectory.num_steps else []
            self._write(
                "/rollout",
                schema.RolloutSample(
                    trial=trial,
                    kind=kind,
                    step=step,
                    time=float(time_s),
                    state=trajectory.states[step].tolist(),
                    measurement=trajectory.measurements[step].tolist(),
                    action=list(action),
                    cost=float(costs[step]),
                    eval_cost=float(eval_costs[step]),
                ),
            )

    def trial_finished(self, trial: int, summary: Mapping[str, Any]) -> None:
        others = other_numbers(summary)

        def number(key: str) -> float:
            value = summary.get(key)
            return 0.0 if value is None or value != value else float(value)  # NaN → 0

        self._write(
            "/trial",
            schema.TrialSummary(
                trial=trial,
                eval_cost=number("eval_cost"),
                success=bool(summary.get("success")),
                optimization_steps=int(number("optimization_steps")),
                fit_seconds=number("fit_seconds"),
                optimization_seconds=number("optimization_seconds"),
                gp_samples=int(number("gp_samples")),
                # calibration (learning trials only): NaN / empty on the exploration trial
                coverage_mean=float(summary.get("coverage_mean", math.nan)),
                nll_mean=float(summary.get("nll_mean", math.nan)),
                coverage=[
                    float(v)
                    for k, v in summary.items()
                    if k.startswith("coverage_") and k != "coverage_mean"
                ],
                nll=[
                    float(v) for k, v in summary.items() if k.startswith("nll_") and k != "nll_mean"
                ],
                other_names=list(others),
                other_values=list(others.values()),
            ),
        )
        assert self._writer is not None
        self._writer.flush()  # closes the chunk: this trial survives a kill from here on

    def close(self) -> None:
        try:
            if self._writer is not None:
                self._writer.finish()
        finally:
            self._writer = None
            if self._stream is not None:
                self._stream.close()  # flushes the footer's last bytes
                self._stream = None


TRIAL_FIELDS = frozenset(name for name, _, _ in schema.MESSAGES["TrialSummary"])


def other_numbers(summary: Mapping[str, Any]) -> dict[str, float]:
    """The numbers (and booleans, as 0/1) of a summary row that ``TrialSummary`` has no field
    for, the per-component calibration columns aside."""
    others = {}
    for key, value in summary.items():
        if key in TRIAL_FIELDS or key.startswith(("coverage_", "nll_")):
            continue
        if isinstance(value, bool | int | float | np.integer | np.floating | np.bool_):
            others[str(key)] = float(value)
    return others
