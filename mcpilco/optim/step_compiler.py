"""torch.compile for a particle rollout's per-time-step functions, with an eager fallback."""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator
from typing import Any

import torch

log = logging.getLogger(__name__)


class StepCompiler:
    """Runs a rollout's time-step functions (:class:`~mcpilco.optim.rollout.ParticleRollout`)
    compiled or eagerly.

    Args:
        compile: ``True``/``False``, or ``"auto"``: compile, and let a
            :class:`~mcpilco.optim.compile_choice.CompileChoice` time the first steps of a
            trial both ways and set :attr:`eager_chosen` to the faster.
        steps_per_call: time steps one compiled call runs (:meth:`chunks`). Each call of a
            compiled function costs its guard checks, wrappers and autograd node whatever
            its size (measured: up to ~26 of a 97 ms optimisation step of the cart-pole
            at M = 400, n = 60 with one step per call); a chunk of steps pays them once and
            lets the compiler fuse across steps. Each distinct chunk length is a graph of
            its own (12 steps: two for a 60-step trial, 12 and 11).

    Attributes:
        compile: compiling is on (switched off for good by :meth:`stop_compiling`).
        choose_compile: ``compile="auto"``.
        eager_chosen: run eagerly for now although compiling is on (set by a CompileChoice).

    Building a compiling one clears PyTorch's in-memory compile caches
    (``torch._dynamo.reset``): PyTorch caps the graphs kept per function (8), and graphs of
    an earlier run in this process (a sweep's jobs, the bench's settings) would use them
    up, after which it silently runs eagerly. Recompiling them is served by its disk cache.
    """

    def __init__(self, compile: bool | str = False, steps_per_call: int = 1) -> None:
        if not isinstance(steps_per_call, int) or steps_per_call < 1:
            raise ValueError(f"compile_steps={steps_per_call!r} must be a positive integer")
        self.steps_per_call = steps_per_call
        self.compile = bool(compile)
        self.choose_compile = compile == "auto"
        self.eager_chosen = False
        self._compiled: dict[str, Callable[..., Any]] = {}
        self._graphs_gp: object = None  # the GP the compiled graphs were made for
        if self.compile:
            torch._dynamo.reset()

    def forget_graphs_of_earlier_fits(self, gp: object) -> None:
        """Clear PyTorch's compile caches once the GP has been refitted (``gp``: the model's
        GP now).

        Each fit brings GP tensors of a new size, and the graphs compiled for the earlier
        sizes are of no further use. PyTorch keeps at most 8 graphs per function and then
        runs it eagerly, silently: with a masked and an unmasked graph per fit, that came
        at trial 5 of a thesis-settings cart-pole run. Cleared here, each fit's graphs are
        compiled for its sizes alone (static shapes).
        """
        if not self.compile or gp is self._graphs_gp:
            return
        if self._graphs_gp is not None:
            torch._dynamo.reset()
            self._compiled.clear()
        self._graphs_gp = gp

    def chunks(self, horizon: int, eager_steps: int) -> Iterator[tuple[int, int, bool]]:
        """``(first, stop, compiled)`` for the time steps ``range(horizon)`` of a rollout:
        the first ``eager_steps`` one at a time and never compiled, then chunks of
        :attr:`steps_per_call` (the last one shorter where they do not divide)."""
        first = 0
        while first < horizon:
            compiled = first >= eager_steps
            stop = min(first + (self.steps_per_call if compiled else 1), horizon)
            yield first, stop, compiled
            first = stop

    def run(self, function: Callable[..., Any], compiled: bool, *args: Any) -> Any:
        """``function(*args)``, through ``torch.compile`` if compiling is on and not set
        aside (:attr:`eager_chosen`), ``compiled`` holds and gradients are recorded (a
        gradient-free rollout, e.g. the particle prediction the loggers store, runs once per
        trial: not worth a graph); a compiler failure switches compilation off with a
        warning."""
        if not (self.compile and not self.eager_chosen and compiled and torch.is_grad_enabled()):
            return function(*args)
        name = function.__name__
        if name not in self._compiled:
            self._compiled[name] = torch.compile(function)
        try:
            return self._compiled[name](*args)
        except Exception as error:  # noqa: BLE001 - any compiler failure: run eagerly
            self.stop_compiling(error)
            return function(*args)

    def stop_compiling(self, error: BaseException) -> None:
        """Run eagerly from now on, with a warning naming the compiler's ``error``."""
        log.warning("torch.compile of the particle step failed (%s); running eagerly", error)
        self.compile = False
