"""Read a run's MCAP log back into arrays and DataFrames (tolerates a killed writer and
damaged records: what is readable is read, each problem is one warning line)."""

from __future__ import annotations

import logging
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from mcap.records import Channel, Message, Metadata, Schema
from mcap_protobuf.decoder import DecoderFactory

from mcpilco.tracking import schema
from mcpilco.tracking.mcap_scan import ScanReport, scan_records
from mcpilco.tracking.schema import TRACE_KEYS

log = logging.getLogger(__name__)


def iter_raw_messages(
    path: Path, report: ScanReport | None = None, metadata: list[dict[str, str]] | None = None
) -> Iterator[tuple[str, Any, bytes]]:
    """``(topic, decoded message, raw bytes)`` for every readable message of the file;
    damage and truncation go to ``report`` (see :mod:`mcpilco.tracking.mcap_scan`), the
    ``run`` metadata records to ``metadata`` when given.

    Messages are decoded with the file's own schemas; where a damaged chunk took the
    channel definitions with it, our writer's fixed channel ids are used (it registers
    one channel per topic of :data:`schema.TOPICS`, in that order, from id 1).
    """
    report = ScanReport() if report is None else report
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    factory = DecoderFactory()
    decoders: dict[int, Any] = {}
    fallback = dict(enumerate(schema.TOPICS.items(), start=1))
    for record in scan_records(path, report):
        if isinstance(record, Metadata):
            if metadata is not None and record.name == "run":
                metadata.append(dict(record.metadata))
        elif isinstance(record, Schema):
            schemas[record.id] = record
        elif isinstance(record, Channel):
            channels[record.id] = record
        elif isinstance(record, Message):
            channel = channels.get(record.channel_id)
            if channel is None or channel.schema_id not in schemas:
                if record.channel_id not in fallback:
                    continue
                topic, message_class = fallback[record.channel_id]
                decode: Any = message_class.FromString
            else:
                topic = channel.topic
                if channel.id not in decoders:
                    decoders[channel.id] = factory.decoder_for(
                        channel.message_encoding, schemas[channel.schema_id]
                    )
                decode = decoders[channel.id]
            try:
                decoded = decode(record.data)
            except Exception:  # a message that does not decode is damage, not a crash
                report.problems.append(f"{path}: a message on {topic} does not decode")
                continue
            yield topic, decoded, record.data


@dataclass
class RunLog:
    """A run's log as tables.

    Attributes:
        rollouts: one row per system sample: trial, kind, step, time, state_i,
            measurement_i, action_i, cost, eval_cost.
        particles: per trial, ``states [T+1, M', d_x]``, ``mean``/``std`` ``[T+1, d_x]``,
            ``cost_mean [T+1]``.
        optimization: one row per optimisation step (trial, step, cost, dropout, ...).
        hyperparameters: one row per (trial, name) with a list of values.
        trials: one row per finished trial (the summary row's numbers, a system's own
            metrics such as ``env_return`` among them).
        metadata: the ``run`` metadata records (one per start or resume).
        truncated: the file ended inside a record (a killed run).
        problems: damaged records that were skipped (the rest is read).
    """

    rollouts: pd.DataFrame
    particles: dict[int, dict[str, np.ndarray]]
    optimization: pd.DataFrame
    hyperparameters: pd.DataFrame
    trials: pd.DataFrame
    metadata: list[dict[str, str]] = field(default_factory=list)
    truncated: bool = False
    problems: list[str] = field(default_factory=list)
    """One line per damaged record that was skipped."""

    def rollout(self, trial: int) -> pd.DataFrame:
        return self.rollouts[self.rollouts["trial"] == trial].reset_index(drop=True)


def _expand(row: dict[str, Any], name: str, values: Any) -> None:
    for index, value in enumerate(values):
        row[f"{name}_{index}"] = value


def read_run_log(path: str | Path) -> RunLog:
    """Load ``rollouts.mcap`` (a path to the file or to its run directory)."""
    path = Path(path)
    if path.is_dir():
        path = path / "rollouts.mcap"
    if not path.is_file():
        raise FileNotFoundError(f"no MCAP log at {path}")
    rollouts, optimization, hyper, trials = [], [], [], []
    particle_steps: dict[int, list[Any]] = {}
    report, metadata = ScanReport(), list[dict[str, str]]()
    for topic, message, _ in iter_raw_messages(path, report, metadata):
        if topic == "/rollout":
            row = {
                "trial": message.trial,
                "kind": message.kind,
                "step": message.step,
                "time": message.time,
                "cost": message.cost,
                "eval_cost": message.eval_cost,
            }
            _expand(row, "state", message.state)
            _expand(row, "measurement", message.measurement)
            _expand(row, "action", message.action)
            rollouts.append(row)
        elif topic == "/particles":
            particle_steps.setdefault(message.trial, []).append(message)
        elif topic == "/optimization":
            optimization.append({f: getattr(message, f) for f in ("trial", "step", *TRACE_KEYS)})
        elif topic == "/gp/hyperparameters":
            hyper.append(
                {"trial": message.trial, "name": message.name, "values": list(message.values)}
            )
        elif topic == "/trial":
            row = {
                f: getattr(message, f)
                for f in (
                    "trial",
                    "eval_cost",
                    "success",
                    "optimization_steps",
                    "fit_seconds",
                    "optimization_seconds",
                    "gp_samples",
                    "coverage_mean",  # calibration (0 in logs written before it existed)
                    "nll_mean",
                )
            }
            _expand(row, "coverage", message.coverage)  # per state component, in order
            _expand(row, "nll", message.nll)
            row.update(zip(message.other_names, message.other_values, strict=False))
            trials.append(row)
    if report.truncated:
        log.warning(
            "%s ends inside a record (a killed or running writer): reading the "
            "complete records before it",
            path,
        )
    for problem in report.problems:
        log.warning("%s", problem)
    particles = {
        trial: {
            "states": np.stack(
                [np.reshape(m.states, (m.num_particles, m.state_dim)) for m in steps]
            ),
            "mean": np.stack([np.asarray(m.mean) for m in steps]),
            "std": np.stack([np.asarray(m.std) for m in steps]),
            "cost_mean": np.asarray([m.cost_mean for m in steps]),
        }
        for trial, steps in particle_steps.items()
    }
    return RunLog(
        pd.DataFrame(rollouts),
        particles,
        pd.DataFrame(optimization),
        pd.DataFrame(hyper),
        pd.DataFrame(trials),
        metadata,
        report.truncated,
        report.problems,
    )
