"""Compiled or eager: whichever the first steps of a trial measure faster."""

from __future__ import annotations

import logging
import statistics
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from mcpilco.optim.step_compiler import StepCompiler

log = logging.getLogger(__name__)


@dataclass
class CompileChoice:
    """Times the first optimisation steps of a trial compiled, then eagerly, and keeps the
    faster for the rest (``compile=auto`` is then never slower than eager; measured: the
    float64 step at n = 300 ran 10 % slower compiled with one thread on our 2-core machine,
    the float32/mixed ones and the n = 60 ones faster). The steps are real optimisation
    steps (both ways give the same result to rounding), so nothing is spent on it but the
    eager steps' extra time when compilation wins.

    Schedule, by step within the trial: ``warmup`` compiled steps (compiling, untimed),
    ``timed`` compiled steps, ``timed`` eager steps; then the choice. Acts only for a rollout
    built with ``compile="auto"`` (``compile=true`` always compiles: the same config and
    seed give the same run bit for bit; a timed choice can differ between runs, and the
    two ways differ by rounding).

    Args:
        compiler: the rollout's :class:`~mcpilco.optim.step_compiler.StepCompiler` (None: a
            rollout without one, which is left as it is).
        warmup, timed: step counts, see above.
    """

    compiler: StepCompiler | None
    warmup: int = 2
    timed: int = 3
    compiled_seconds: list[float] = field(default_factory=list)
    eager_seconds: list[float] = field(default_factory=list)
    decided: bool = False

    def __post_init__(self) -> None:
        # a rollout built with compile="auto" only (None: a user's rollout without a compiler)
        self.decided = not (
            self.compiler is not None and self.compiler.compile and self.compiler.choose_compile
        )
        if self.compiler is not None and not self.decided:
            self.compiler.eager_chosen = False

    def before(self, step: int) -> None:
        """Set the rollout up for step ``step`` (0-based, within this trial or stage)."""
        if not self.decided:
            assert self.compiler is not None  # undecided only with a compiler
            self.compiler.eager_chosen = step >= self.warmup + self.timed

    def after(self, step: int, seconds: float) -> None:
        """Record the wall time of step ``step``; choose once both ways are timed."""
        if self.decided or step < self.warmup:
            return
        assert self.compiler is not None  # undecided only with a compiler
        if not self.compiler.compile:  # the compiler failed meanwhile: eager it is
            self.decided = True
            return
        timed = self.eager_seconds if self.compiler.eager_chosen else self.compiled_seconds
        timed.append(seconds)
        if len(self.eager_seconds) == self.timed:
            compiled = statistics.median(self.compiled_seconds)
            eager = statistics.median(self.eager_seconds)
            self.compiler.eager_chosen = eager < compiled
            self.decided = True
            log.info(
                "step %.1f ms compiled, %.1f ms eager: running %s",
                compiled * 1e3,
                eager * 1e3,
                "eagerly" if self.compiler.eager_chosen else "compiled",
            )
