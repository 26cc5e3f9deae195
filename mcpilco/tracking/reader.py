"""Read a run's MCAP log back into arrays and DataFrames (tolerates a killed writer)."""

from __future__ import annotations

import logging
import struct
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import zstandard
from mcap.exceptions import InvalidMagic, McapError
from mcap.records import Channel, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap_protobuf.decoder import DecoderFactory

from mcpilco.tracking.schema import TRACE_KEYS

log = logging.getLogger(__name__)


class TruncatedLogError(ValueError):
    """The log ends inside a record: the writer was killed. What came before is usable."""


def _records(path: Path) -> Iterator[Any]:
    """Records in file order; stops (with a warning) where a killed writer left off."""
    with open(path, "rb") as handle:
        reader = StreamReader(handle, validate_crcs=True)
        try:
            yield from reader.records
        except InvalidMagic as error:
            raise ValueError(f"{path} is not an MCAP file (bad magic bytes)") from error
        except (McapError, EOFError, ValueError, struct.error, zstandard.ZstdError) as error:
            raise TruncatedLogError(f"{path} ends early ({type(error).__name__})") from error


def iter_raw_messages(path: Path) -> Iterator[tuple[str, Any, bytes]]:
    """``(topic, decoded message, raw bytes)`` for every complete message of the file."""
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    factory = DecoderFactory()
    decoders: dict[int, Any] = {}
    try:
        for record in _records(path):
            if isinstance(record, Schema):
                schemas[record.id] = record
            elif isinstance(record, Channel):
                channels[record.id] = record
            elif isinstance(record, Message):
                channel = channels[record.channel_id]
                if channel.id not in decoders:
                    decoders[channel.id] = factory.decoder_for(
                        channel.message_encoding, schemas[channel.schema_id]
                    )
                yield channel.topic, decoders[channel.id](record.data), record.data
    except TruncatedLogError:
        return


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
        trials: one row per finished trial.
        metadata: the ``run`` metadata records (one per start or resume).
        truncated: the file ended inside a record (a killed run).
    """

    rollouts: pd.DataFrame
    particles: dict[int, dict[str, np.ndarray]]
    optimization: pd.DataFrame
    hyperparameters: pd.DataFrame
    trials: pd.DataFrame
    metadata: list[dict[str, str]] = field(default_factory=list)
    truncated: bool = False

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
    truncated = False
    for topic, message, _ in iter_raw_messages(path):
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
            trials.append(
                {
                    f: getattr(message, f)
                    for f in (
                        "trial",
                        "eval_cost",
                        "success",
                        "optimization_steps",
                        "fit_seconds",
                        "optimization_seconds",
                        "gp_samples",
                    )
                }
            )
    metadata = []
    try:
        for record in _records(path):
            if isinstance(record, Metadata) and record.name == "run":
                metadata.append(dict(record.metadata))
    except TruncatedLogError as error:
        truncated = True
        log.warning(
            "%s: reading the complete records before it (a killed or running writer)", error
        )
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
        truncated,
    )
