"""Protobuf messages of the MCAP log, built from descriptors at import (no protoc step).

Protobuf rather than JSON so that standard tools decode typed fields: ``rerun mcap convert``
turns protobuf channels into typed columns (JSON ones only into raw bytes), and the ``mcap``
CLI and Foxglove read them too. Arrays are ``repeated double`` fields, row-major.
"""

from __future__ import annotations

from typing import Any

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

PACKAGE = "mcpilco"
_T = descriptor_pb2.FieldDescriptorProto

# message name → [(field, type, repeated)]
MESSAGES: dict[str, list[tuple[str, int, bool]]] = {
    "RolloutSample": [
        ("trial", _T.TYPE_INT32, False),
        ("kind", _T.TYPE_STRING, False),
        ("step", _T.TYPE_INT32, False),
        ("time", _T.TYPE_DOUBLE, False),
        ("state", _T.TYPE_DOUBLE, True),
        ("measurement", _T.TYPE_DOUBLE, True),
        ("action", _T.TYPE_DOUBLE, True),
        ("cost", _T.TYPE_DOUBLE, False),
        ("eval_cost", _T.TYPE_DOUBLE, False),
    ],
    "ParticleSample": [
        ("trial", _T.TYPE_INT32, False),
        ("step", _T.TYPE_INT32, False),
        ("time", _T.TYPE_DOUBLE, False),
        ("num_particles", _T.TYPE_INT32, False),
        ("state_dim", _T.TYPE_INT32, False),
        ("states", _T.TYPE_DOUBLE, True),
        ("mean", _T.TYPE_DOUBLE, True),
        ("std", _T.TYPE_DOUBLE, True),
        ("cost_mean", _T.TYPE_DOUBLE, False),
    ],
    "OptimizationStep": [
        ("trial", _T.TYPE_INT32, False),
        ("step", _T.TYPE_INT32, False),
        ("cost", _T.TYPE_DOUBLE, False),
        ("dropout", _T.TYPE_DOUBLE, False),
        ("learning_rate", _T.TYPE_DOUBLE, False),
        ("signal", _T.TYPE_DOUBLE, False),
        ("horizon", _T.TYPE_INT32, False),
    ],
    "Hyperparameter": [
        ("trial", _T.TYPE_INT32, False),
        ("name", _T.TYPE_STRING, False),
        ("values", _T.TYPE_DOUBLE, True),
    ],
    "TrialSummary": [
        ("trial", _T.TYPE_INT32, False),
        ("eval_cost", _T.TYPE_DOUBLE, False),
        ("success", _T.TYPE_BOOL, False),
        ("optimization_steps", _T.TYPE_INT32, False),
        ("fit_seconds", _T.TYPE_DOUBLE, False),
        ("optimization_seconds", _T.TYPE_DOUBLE, False),
        ("gp_samples", _T.TYPE_INT32, False),
        ("coverage_mean", _T.TYPE_DOUBLE, False),
        ("nll_mean", _T.TYPE_DOUBLE, False),
        ("coverage", _T.TYPE_DOUBLE, True),  # per state component (calibration.py)
        ("nll", _T.TYPE_DOUBLE, True),
        # the summary row's other numbers, by name (a system's own metrics, e.g. a Gymnasium
        # environment's env_return; empty in logs written before they were kept)
        ("other_names", _T.TYPE_STRING, True),
        ("other_values", _T.TYPE_DOUBLE, True),
    ],
}


def _build() -> dict[str, Any]:
    file = descriptor_pb2.FileDescriptorProto(
        name="mcpilco/tracking.proto", package=PACKAGE, syntax="proto3"
    )
    for name, fields in MESSAGES.items():
        message = file.message_type.add(name=name)
        for number, (field, kind, repeated) in enumerate(fields, start=1):
            label = _T.LABEL_REPEATED if repeated else _T.LABEL_OPTIONAL
            message.field.add(name=field, number=number, type=kind, label=label)
    pool = descriptor_pool.DescriptorPool()
    pool.Add(file)
    return {
        name: message_factory.GetMessageClass(pool.FindMessageTypeByName(f"{PACKAGE}.{name}"))
        for name in MESSAGES
    }


CLASSES = _build()
RolloutSample = CLASSES["RolloutSample"]
ParticleSample = CLASSES["ParticleSample"]
OptimizationStep = CLASSES["OptimizationStep"]
Hyperparameter = CLASSES["Hyperparameter"]
TrialSummary = CLASSES["TrialSummary"]

# The per-step columns of an optimisation trace (OptimizationStep after trial and step).
TRACE_KEYS: tuple[str, ...] = tuple(name for name, _, _ in MESSAGES["OptimizationStep"][2:])

TOPICS = {
    "/rollout": RolloutSample,
    "/particles": ParticleSample,
    "/optimization": OptimizationStep,
    "/gp/hyperparameters": Hyperparameter,
    "/trial": TrialSummary,
}
