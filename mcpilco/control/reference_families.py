"""The ``reference`` group of ``runners.control``: which joint references a run tracks.

Every family is checked when it is built and against the robot's joint count in
:meth:`ReferenceFamily.references` — both before any data collection, fit or simulation —
with a one-line :class:`~mcpilco.errors.ConfigError` naming ``reference.<key>``.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import Any

import numpy as np
from omegaconf import ListConfig

from mcpilco.checks import integer, number
from mcpilco.control.references import Reference, SineReference, SumOfSinesReference
from mcpilco.errors import ConfigError
from mcpilco.extension import ExtensionPoint


class ReferenceFamily(ExtensionPoint, ABC):
    """The references one control run tracks, in order (``reference._target_``).

    Subclass it for your own (``reference._target_=my_pkg.MyReferences``): return
    :class:`~mcpilco.control.references.Reference` objects with distinct labels.
    """

    @abstractmethod
    def references(self, num_joints: int) -> list[Reference]:
        """The references for an n-joint robot (one-line error if they do not fit it)."""


def _seeds(value: Any) -> list[int]:
    if isinstance(value, str) or not isinstance(value, Sequence | ListConfig) or not len(value):
        raise ConfigError(f"reference.seeds={value!r} must be a non-empty list of integers")
    seeds = [integer(f"reference.seeds[{i}]", s) for i, s in enumerate(value)]
    if len(set(seeds)) != len(seeds):
        raise ConfigError(f"reference.seeds={seeds} names a seed twice")
    return seeds


def _is_list(value: Any) -> bool:
    return isinstance(value, Sequence | ListConfig) and not isinstance(value, str | bytes)


def per_joint(key: str, value: Any, num_joints: int) -> np.ndarray:
    """A number (every joint) or a list of n finite numbers: ``[n]``."""
    if value is None:
        return np.zeros(num_joints)
    if _is_list(value):
        items = list(value)
        if len(items) != num_joints:
            raise ConfigError(
                f"{key}={items!r} must have one entry per joint ({num_joints}), it has {len(items)}"
            )
        return np.array([number(f"{key}[{j}]", v) for j, v in enumerate(items)])
    return np.full(num_joints, number(key, value))


def terms_per_joint(
    key: str,
    value: Any,
    num_joints: int,
    counts: Sequence[int] | None = None,
    minimum: float | None = None,
) -> tuple[np.ndarray, ...]:
    """n entries, each a number (one term) or a list of numbers (its terms): one
    ``[K_j]`` array per joint; with ``counts``, joint j must have ``counts[j]`` terms."""
    if not _is_list(value) or len(value) != num_joints:
        raise ConfigError(
            f"{key}={value!r} must be a list of one entry per joint ({num_joints}), each a "
            "number or a list of numbers (one per term)"
        )
    joints = []
    for j, entry in enumerate(value):
        items = list(entry) if _is_list(entry) else [entry]
        if not items:
            raise ConfigError(f"{key}[{j}]=[] must hold at least one term")
        values = [number(f"{key}[{j}][{k}]", v, minimum=minimum) for k, v in enumerate(items)]
        if counts is not None and len(values) != counts[j]:
            raise ConfigError(
                f"{key}[{j}]={values} has {len(values)} terms but reference.amplitudes[{j}] "
                f"has {counts[j]}"
            )
        joints.append(np.array(values))
    return tuple(joints)


class ThesisSines(ReferenceFamily):
    """The thesis's family (§5.4.2): one reference per seed, r_j(t) = o_j + A t sin(2π F_j t)
    with F_j ~ N(frequency_mean, frequency_std²) drawn from ``numpy.random.default_rng(seed)``.

    Args:
        seeds: one reference per seed (labels ``seed_00``, ``seed_01``, ...).
        duration: s. amplitude: A in rad/s.
        frequency_mean: Hz, a number or one per joint. frequency_std: Hz.
        offsets: o_j in rad, a number or one per joint (null: 0, the thesis's).
    """

    def __init__(
        self,
        seeds: Sequence[int] = (0, 1, 2),
        duration: float = 5.0,
        amplitude: float = 0.165,
        frequency_mean: float | Sequence[float] = 0.5,
        frequency_std: float = 1.0,
        offsets: float | Sequence[float] | None = None,
    ) -> None:
        self.seeds = _seeds(seeds)
        self.duration = number("reference.duration", duration, above=0)
        self.amplitude = number("reference.amplitude", amplitude)
        if not _is_list(frequency_mean):
            number("reference.frequency_mean", frequency_mean)
        self.frequency_mean = frequency_mean
        self.frequency_std = number("reference.frequency_std", frequency_std, minimum=0)
        self.offsets = offsets
        if not _is_list(offsets) and offsets is not None:
            number("reference.offsets", offsets)

    def references(self, num_joints: int) -> list[Reference]:
        mean = per_joint("reference.frequency_mean", self.frequency_mean, num_joints)
        offsets = per_joint("reference.offsets", self.offsets, num_joints)
        return [
            SineReference.random(
                np.random.default_rng(seed),
                num_joints,
                self.amplitude,
                mean,
                self.frequency_std,
                offsets=offsets,
                duration=self.duration,
                label=f"seed_{seed:02d}",
            )
            for seed in self.seeds
        ]


class SumOfSines(ReferenceFamily):
    """One explicit reference r_j(t) = o_j + Σ_k A_jk sin(2π f_jk t + φ_jk).

    Args:
        amplitudes: rad; one entry per joint, a number (one term) or a list (its terms).
        frequencies: Hz (≥ 0), the same shape as ``amplitudes``.
        phases: rad, the same shape (null: every phase 0).
        offsets: o_j in rad, a number or one per joint.
        duration: s. label: the reference's name in the run.
    """

    def __init__(
        self,
        amplitudes: Sequence[Any],
        frequencies: Sequence[Any],
        phases: Sequence[Any] | None = None,
        offsets: float | Sequence[float] = 0.0,
        duration: float = 5.0,
        label: str = "sines",
    ) -> None:
        self.amplitudes, self.frequencies, self.phases = amplitudes, frequencies, phases
        self.offsets = offsets
        self.duration = number("reference.duration", duration, above=0)
        if (
            not isinstance(label, str)
            or not label.replace("_", "").replace("-", "").replace(".", "").isalnum()
        ):
            raise ConfigError(f"reference.label={label!r} must be letters, digits, '_', '-' or '.'")
        self.label = label

    def references(self, num_joints: int) -> list[Reference]:
        amplitudes = terms_per_joint("reference.amplitudes", self.amplitudes, num_joints)
        counts = [len(a) for a in amplitudes]
        frequencies = terms_per_joint(
            "reference.frequencies", self.frequencies, num_joints, counts, minimum=0
        )
        phases = (
            tuple(np.zeros(c) for c in counts)
            if self.phases is None
            else terms_per_joint("reference.phases", self.phases, num_joints, counts)
        )
        offsets = per_joint("reference.offsets", self.offsets, num_joints)
        return [
            SumOfSinesReference(amplitudes, frequencies, phases, offsets, self.duration, self.label)
        ]


class RandomSumOfSines(ReferenceFamily):
    """One multi-sine reference per seed: per joint ``terms`` sines with frequencies
    uniform in [``frequency_low``, ``frequency_high``] Hz, phases uniform in [0, 2π) and
    amplitudes a random split of ``amplitude`` rad (so |r_j − o_j| ≤ ``amplitude``), all
    drawn from ``numpy.random.default_rng(seed)``.

    Args:
        seeds: one reference per seed (labels ``seed_00``, ...). terms: K per joint.
        amplitude: rad. frequency_low, frequency_high: Hz. offsets: rad (number or per
        joint). duration: s.
    """

    def __init__(
        self,
        seeds: Sequence[int] = (0, 1, 2),
        terms: int = 3,
        amplitude: float = 0.8,
        frequency_low: float = 0.1,
        frequency_high: float = 1.0,
        offsets: float | Sequence[float] | None = None,
        duration: float = 5.0,
    ) -> None:
        self.seeds = _seeds(seeds)
        self.terms = integer("reference.terms", terms, minimum=1)
        self.amplitude = number("reference.amplitude", amplitude, minimum=0)
        self.frequency_low = number("reference.frequency_low", frequency_low, minimum=0)
        self.frequency_high = number(
            "reference.frequency_high", frequency_high, minimum=self.frequency_low
        )
        self.offsets = offsets
        self.duration = number("reference.duration", duration, above=0)

    def references(self, num_joints: int) -> list[Reference]:
        offsets = per_joint("reference.offsets", self.offsets, num_joints)
        result: list[Reference] = []
        for seed in self.seeds:
            rng = np.random.default_rng(seed)
            shape = (num_joints, self.terms)
            frequencies = rng.uniform(self.frequency_low, self.frequency_high, shape)
            phases = rng.uniform(0.0, 2 * math.pi, shape)
            split = rng.uniform(0.0, 1.0, shape)
            amplitudes = self.amplitude * split / split.sum(axis=1, keepdims=True)
            result.append(
                SumOfSinesReference(
                    tuple(amplitudes),
                    tuple(frequencies),
                    tuple(phases),
                    offsets,
                    self.duration,
                    f"seed_{seed:02d}",
                )
            )
        return result
