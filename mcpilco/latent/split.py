"""Which sequences of a cloth data set train a CGPDM and which test it (``data.*`` keys).

By default (the thesis's study) the last ``num_test`` sequences are the test set and a
training set of ``num_train`` is drawn from the others: draw ``k`` is a random permutation
seeded by k and the set is its first ``num_train`` (the sets of one draw are nested,
5 ⊂ 10 ⊂ …). Explicit lists of sequence numbers — the data set's own numbering: the index
of a simulated sequence, the trailing number of a CSV file — replace either rule and then
the count (``num_train`` / ``num_test``) they stand for; the training set is still drawn
from the non-test sequences when only the test set is given. The two sets must be disjoint
unless ``allow_overlap``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from mcpilco.cloth.dataset import ClothDataset
from mcpilco.errors import ConfigError


def sequence_numbers(key: str, value: Any) -> tuple[int, ...] | None:
    """``value`` as distinct non-negative sequence numbers (None stays None); a one-line
    :class:`ConfigError` naming ``key`` otherwise."""
    if value is None:
        return None
    items = [] if isinstance(value, str) or not hasattr(value, "__iter__") else list(value)
    if not items:
        raise ConfigError(f"{key}={value!r} must be a non-empty list of sequence numbers or null")
    if not all(isinstance(i, int) and not isinstance(i, bool) and i >= 0 for i in items):
        raise ConfigError(f"{key}={items!r} must hold non-negative integers (sequence numbers)")
    if len(set(items)) != len(items):
        repeated = sorted({i for i in items if items.count(i) > 1})
        raise ConfigError(f"{key}={items!r} lists {repeated} more than once")
    return tuple(items)


@dataclass(frozen=True)
class SequenceSplit:
    """The split rule of one run.

    Attributes:
        num_train, num_test: counts for the default rules.
        draw: the seed of the training-set permutation.
        train, test: explicit sequence numbers, or None for the default rule.
        allow_overlap: whether a sequence may be in both sets.
    """

    num_train: int
    num_test: int
    draw: int
    train: tuple[int, ...] | None = None
    test: tuple[int, ...] | None = None
    allow_overlap: bool = False

    def __post_init__(self) -> None:
        if self.train is not None and self.test is not None and not self.allow_overlap:
            both = sorted(set(self.train) & set(self.test))
            if both:
                raise ConfigError(
                    f"data.train_sequences and data.test_sequences share {both} "
                    "(data.allow_overlap=true allows it)"
                )

    @property
    def counts(self) -> tuple[int, int]:
        """(training, test) sequences this rule gives."""
        train = self.num_train if self.train is None else len(self.train)
        return train, self.num_test if self.test is None else len(self.test)

    def check_numbers(self, available: Sequence[int]) -> None:
        """Every explicit number names a sequence of ``available``, and the default rules
        have enough sequences; one line naming the key otherwise."""
        known = set(int(i) for i in available)
        for key, numbers in (("train", self.train), ("test", self.test)):
            if numbers is not None and not set(numbers) <= known:
                missing = sorted(set(numbers) - known)
                raise ConfigError(
                    f"data.{key}_sequences names {missing}, not in the data set (sequences "
                    f"{min(known)}..{max(known)}, {len(known)} of them)"
                )
        total, (train, test) = len(known), self.counts
        if self.test is None and not 1 <= test < total:
            raise ConfigError(
                f"data.num_test={test} must be in [1, {total - 1}] (the data set has "
                f"{total} sequences)"
            )
        test_set = set(self.test) if self.test is not None else set(sorted(known)[total - test :])
        if self.train is None and not 1 <= train <= total - len(test_set & known):
            raise ConfigError(
                f"data.num_train={train} must be in [1, {total - len(test_set)}]: {total} "
                f"sequences minus {len(test_set)} for test"
            )

    def rows(self, dataset: ClothDataset) -> tuple[list[int], list[int]]:
        """Row numbers of (training set, test set) in ``dataset``."""
        numbers = [int(i) for i in dataset.indices]
        self.check_numbers(numbers)
        row_of = {number: row for row, number in enumerate(numbers)}
        total = len(numbers)
        if self.test is None:
            test_rows = list(range(total - self.num_test, total))
        else:
            test_rows = [row_of[i] for i in self.test]
        if self.train is not None:
            return [row_of[i] for i in self.train], test_rows
        excluded = set(test_rows)
        candidates = [row for row in range(total) if row not in excluded]
        order = np.random.default_rng(np.random.SeedSequence([self.draw, 0xC10])).permutation(
            len(candidates)
        )
        return sorted(candidates[int(i)] for i in order[: self.num_train]), test_rows

    def record(self, dataset: ClothDataset, train_rows: list[int], test_rows: list[int]) -> dict:
        """What the run directory keeps of the split (``training_set.json``)."""
        return {
            "draw": self.draw,
            "train_rule": "given" if self.train is not None else f"drawn (seed {self.draw})",
            "test_rule": "given" if self.test is not None else f"the last {self.num_test}",
            "train": [int(dataset.indices[r]) for r in train_rows],
            "test": [int(dataset.indices[r]) for r in test_rows],
        }
