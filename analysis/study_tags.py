"""Tell apart runs whose thesis-style labels agree but whose configs do not.

:func:`analysis.thesis.configuration_label` names the dimensions of the thesis's tables
(model, kernel, dropout, cost, system, protocol, precision, reduction). A sweep over
anything else — ``optimizer.schedule.window=100,200``, ``optimizer.num_particles``, a
policy setting — would otherwise pool different experiments into one row of a report.
:func:`distinguished_labels` appends, to each run's label, the config values in which it
differs from the other runs of that label, e.g. ``S.I., SE, dropout, l=(3,1)
[optimizer.schedule.window=100]``.

Not compared: the seed, the machine keys (threads, device, compile, …: they do not make
another experiment) and the ``tracking`` settings. A key some runs of the label lack comes
from a config written before the key existed, and what such a run did is not known from its
config (a new key's default usually keeps the old behaviour, but defaults change later:
``model.gp.forward_gradient``). So such a key is compared only where a run sets it to
something other than today's default (``defaults``, the composed ``conf/train.yaml``), and
the runs without it show ``—``: a run with ``optimizer.schedule.bias_correction=true`` is
told apart from older runs, which are never said to have had a value. Without ``defaults``
such keys are not compared.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Mapping, Sequence
from typing import Any

from mcpilco.run_storage import MACHINE_KEYS

IGNORED_KEYS = frozenset({"seed", *MACHINE_KEYS})
"""Top-level keys that do not make a run another experiment: the seed and the machine keys."""

IGNORED_GROUPS = ("tracking",)
"""Top-level groups that only say where and how a run is logged."""


LIST_MARK = "#"
"""Marks a list index in a flattened key (dropped when the key is shown)."""

ABSENT = "—"
"""Shown for a key that a run's config does not have."""


def flatten(config: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Dotted key → leaf value of a nested config; a list of mappings (e.g. a sum kernel's
    ``terms``) is entered with its indices as keys (``kernel.terms.1.weight``), other lists
    are leaves (as tuples, so that leaves can be compared)."""
    leaves: dict[str, Any] = {}
    for key, value in config.items():
        dotted = f"{prefix}{key}"
        if isinstance(value, Mapping):
            leaves.update(flatten(value, f"{dotted}."))
        elif isinstance(value, (list, tuple)) and any(isinstance(v, Mapping) for v in value):
            items = {str(i): v for i, v in enumerate(value)}
            leaves.update(flatten(items, f"{dotted}.{LIST_MARK}"))
        elif isinstance(value, (list, tuple)):
            leaves[dotted] = tuple(value)
        else:
            leaves[dotted] = value
    return leaves


def _compared(key: str) -> bool:
    top = key.split(".", 1)[0]
    return top not in IGNORED_KEYS and top not in IGNORED_GROUPS


def set_apart(leaves: Sequence[Mapping[str, Any]], defaults: Mapping[str, Any]) -> set[str]:
    """Keys (outside lists) that some of these flattened configs lack and one of them sets
    to a value other than its default in ``defaults``."""
    every = set().union(*leaves)
    partial = {key for key in every if LIST_MARK not in key and any(key not in x for x in leaves)}
    return {
        key
        for key in partial
        if key in defaults
        and any(key in leaf and repr(leaf[key]) != repr(defaults[key]) for leaf in leaves)
    }


def distinguished_labels(
    labels: Mapping[str, str],
    configs: Mapping[str, Mapping[str, Any]],
    defaults: Mapping[str, Any] | None = None,
) -> dict[str, str]:
    """Each run's label with ``[key=value; …]`` appended where runs of that label differ.

    Args:
        labels: run → thesis-style label. configs: run → its resolved config (nested dicts).
        defaults: today's default config, flattened (:func:`flatten`), for keys an older
            config lacks (see the module's docstring); None: such keys are not compared.
    Returns:
        run → label, unchanged where all runs of the label agree on every compared key.
    """
    by_label: dict[str, list[str]] = defaultdict(list)
    for run, label in labels.items():
        by_label[label].append(run)
    result = dict(labels)
    for label, runs in by_label.items():
        if len(runs) < 2:
            continue
        leaves = {run: flatten(configs[run]) for run in runs}
        shared = set.intersection(*(set(leaf) for leaf in leaves.values()))
        # keys inside a list (a kernel's terms) are the user's choice of structure: one
        # that some runs lack is a difference; elsewhere a missing key is an older config
        in_lists = {key for leaf in leaves.values() for key in leaf if LIST_MARK in key}
        newer = set_apart(list(leaves.values()), defaults) if defaults is not None else set()
        differing = sorted(
            key
            for key in shared | in_lists | newer
            if _compared(key) and len({repr(leaves[run].get(key, ABSENT)) for run in runs}) > 1
        )
        if not differing:
            continue
        for run in runs:
            values = "; ".join(
                f"{key.replace(LIST_MARK, '')}={_text(leaves[run].get(key, ABSENT))}"
                for key in differing
            )
            result[run] = f"{label} [{values}]"
    return result


def _text(value: Any) -> str:
    if isinstance(value, tuple):
        return "[" + ",".join(_text(v) for v in value) + "]"
    return str(value)
