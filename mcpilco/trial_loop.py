"""The trial loop of MC-PILCO (thesis Algorithm 1): explore, then fit → optimise → run."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
import torch
from torch import nn

from mcpilco.calibration import calibration
from mcpilco.checks import require_finite
from mcpilco.controller import PolicyController
from mcpilco.errors import NonFiniteError, NotPositiveDefiniteError, SimulationError
from mcpilco.estimators.base import StateEstimator
from mcpilco.models.base import ModelStructure
from mcpilco.optim.base import PolicySearch, StepInfo
from mcpilco.optim.convergence import steps_to_final
from mcpilco.optim.policy_optimizer import frozen
from mcpilco.optim.rollout import ParticleRollout
from mcpilco.policies.rbf import SquashedRBFPolicy
from mcpilco.run_storage import RunDirectory
from mcpilco.seeding import RandomStreams
from mcpilco.systems.base import Controller, MechanicalSystem
from mcpilco.tracking.base import TrialObserver
from mcpilco.trajectory import Trajectory
from mcpilco.trial_report import trial_line

log = logging.getLogger(__name__)

ExplorationFactory = Callable[..., Controller]
"""Called as ``factory(rng=...)`` with the system's random generator."""


@dataclass
class Components:
    """Everything a run is made of, built from the config by :mod:`mcpilco.build`."""

    system: MechanicalSystem
    model: ModelStructure
    policy: SquashedRBFPolicy
    cost: nn.Module
    estimator: StateEstimator
    optimizer: PolicySearch
    exploration: ExplorationFactory
    simulate_estimator: bool = True
    compile: bool | str = False
    """torch.compile the particle step: true, false or ``"auto"`` (see
    :class:`ParticleRollout`)."""
    compile_steps: int = 1
    """Time steps per compiled call (see :class:`ParticleRollout`)."""
    rollout_dtype: torch.dtype | None = None
    """The particles' dtype in policy optimisation (None: the run's ``dtype``; float32 with
    float64: the mixed setting, see :class:`ParticleRollout`)."""


class TrialLoop:
    """Runs exploration and ``num_trials`` learning trials, storing each as it finishes.

    Args:
        components: system, model, policy, cost, estimator, optimiser, exploration.
        storage: the run directory.
        streams: random streams (same seed → same run).
        num_trials: learning trials after the exploration rollout.
    """

    def __init__(
        self,
        components: Components,
        storage: RunDirectory,
        streams: RandomStreams,
        num_trials: int,
        observers: Sequence[TrialObserver] = (),
        metadata: Mapping[str, str] | None = None,
    ) -> None:
        self.c = components
        self.observers = list(observers)
        self.metadata = dict(metadata or {})
        self.storage = storage
        self.streams = streams
        self.num_trials = num_trials
        c = components
        self.rollout = ParticleRollout.for_system(
            c.system,
            c.model,
            c.policy,
            c.cost,
            c.estimator,
            c.simulate_estimator,
            c.compile,
            c.rollout_dtype,
            c.compile_steps,
        )
        self.trajectories: list[Trajectory] = []
        self._trial_started = time.time()  # set again when the loop starts and per trial

    def run(
        self,
        on_step: Callable[[int, StepInfo], None] | None = None,
        on_trial: Callable[[dict[str, Any]], None] | None = None,
    ) -> pd.DataFrame:
        """Algorithm 1. Returns the per-trial summary (also in ``summary.csv``).

        If the run directory already holds finished trials (a killed run), the loop
        continues after the last one with its data, policy and random-generator states,
        so the resumed run equals an uninterrupted one.
        """
        try:
            return self._run(on_step, on_trial)
        finally:
            for observer in self.observers:
                observer.close()

    def _run(
        self,
        on_step: Callable[[int, StepInfo], None] | None,
        on_trial: Callable[[dict[str, Any]], None] | None,
    ) -> pd.DataFrame:
        self._trial_started = time.time()
        first = self._restore()
        for observer in self.observers:
            observer.run_started(self.metadata, first - 1)
        if first == 0:
            log.info("trial 0: exploration rollout on the system")
            start = time.perf_counter()
            exploration = self._interact(self.c.exploration(rng=self.streams.system), 0)
            table = self._record(0, exploration, {"rollout_seconds": time.perf_counter() - start})
            if on_trial is not None:
                on_trial(table.iloc[-1].to_dict())
            first = 1
        table = self.storage.summary()
        for trial in range(first, self.num_trials + 1):
            log.info(
                "trial %d/%d: fitting the GPs on %d rollouts",
                trial,
                self.num_trials,
                len(self.trajectories),
            )
            fit = self._learn_model(trial)
            log.info(
                "trial %d/%d: GPs fitted on n=%d samples (kept %d) in %.1f s; "
                "optimising the policy%s",
                trial,
                self.num_trials,
                fit.num_samples,
                fit.num_kept,
                fit.seconds,
                " (compiling the particle step first: 5-15 s per graph the first time, then cached)"
                if self.c.compile
                else "",
            )
            start = time.perf_counter()
            result = self.c.optimizer.optimize(
                self.rollout,
                trial,
                self.streams.particles,
                None if on_step is None else (lambda info, k=trial: on_step(k, info)),
            )
            optimization_seconds = time.perf_counter() - start
            if not result.costs:
                self._no_finite_step(trial, result.restarts)
            trace = {
                "cost": result.costs,
                "dropout": result.dropouts,
                "learning_rate": result.learning_rates,
                "signal": result.signals,
                "horizon": result.horizons,
            }
            self.storage.save_optimization_trace(trial, trace)
            start = time.perf_counter()
            for observer in self.observers:
                observer.optimized(trial, trace)
            predicted = self._predict_particles(trial)
            logging_seconds = time.perf_counter() - start
            start = time.perf_counter()
            controller = PolicyController(self.c.policy, self.c.model, self.c.estimator)
            trajectory = self._interact(controller, trial)
            rollout_seconds = time.perf_counter() - start
            # a real rollout longer than the search horizon is compared over the horizon
            # (one that ended early, a terminated episode, over its own steps)
            real = trajectory.states[: len(predicted)]
            figures = calibration(predicted, real, self.c.system.state_names)
            self.storage.save_checkpoint(trial, "policy", self.c.policy.state_dict())
            self.storage.save_checkpoint(trial, "model", self.c.model.checkpoint())
            row = {
                "gp_samples": fit.num_samples,
                "gp_kept": fit.num_kept,
                "gp_nll": fit.negative_log_likelihood,
                "fit_seconds": fit.seconds,
                "optimization_steps": result.steps,
                "optimization_seconds": optimization_seconds,
                "final_particle_cost": result.costs[-1] if result.costs else float("nan"),
                "steps_to_final": steps_to_final(result.costs),
                "policy_restarts": result.restarts,
                "rollout_seconds": rollout_seconds,
                "logging_seconds": logging_seconds,
                **figures,
            }
            table = self._record(trial, trajectory, row)
            if on_trial is not None:
                on_trial(table.iloc[-1].to_dict())
        return table

    def _restore(self) -> int:
        """Load the finished trials of an interrupted run; return the next trial."""
        last = self.storage.finished_trials()
        if last < 0:
            return 0
        self.trajectories = [self.storage.load_trajectory(k) for k in range(last + 1)]
        if last >= 1:
            self.c.policy.load_state_dict(self.storage.load_checkpoint(last, "policy"))
        self.streams.restore(self.storage.load_random_state(last))
        log.info("resuming %s after trial %d", self.storage.path, last)
        return last + 1

    def _saved_note(self, trial: int) -> str:
        if trial == 0:
            return "no trial finished"
        return f"trials 0..{trial - 1} are saved in {self.storage.path}"

    def _learn_model(self, trial: int) -> Any:
        """Step 1: train the GPs on all data so far (offline state estimates)."""
        estimator, dt = self.c.estimator, self.c.system.dt
        states = [estimator.offline(t.measurements, dt, t.actions) for t in self.trajectories]
        actions = [t.actions for t in self.trajectories]
        for data_trial, estimate in enumerate(states):
            rows = np.flatnonzero(~np.isfinite(estimate).all(axis=1))
            if rows.size:
                what = f"the offline state estimate of trial {data_trial}'s rollout"
                try:
                    require_finite(estimate[rows[0]], what, int(rows[0]), self.c.system.state_names)
                except NonFiniteError as error:
                    raise NonFiniteError(
                        f"trial {trial}: {error} ({self._saved_note(trial)})"
                    ) from None
        try:
            report = self.c.model.fit(states, actions)
        except NotPositiveDefiniteError as error:
            raise NotPositiveDefiniteError(
                f"trial {trial}: {error} ({self._saved_note(trial)})"
            ) from error
        if self.c.model.fits_gps and not np.isfinite(report.negative_log_likelihood):
            raise NonFiniteError(
                f"trial {trial}: the GP fit ended at -log p(y|X)/N = "
                f"{report.negative_log_likelihood} ({self._saved_note(trial)})"
            )
        hyperparameters = self.c.model.hyperparameters()
        for observer in self.observers:
            observer.model_fitted(trial, hyperparameters)
        return report

    def _predict_particles(self, trial: int) -> np.ndarray:
        """Simulate the final (deterministic) policy's particles ``[T+1, M, d_x]`` on the
        model, for the observers and the trial's calibration figures."""
        with torch.no_grad(), frozen(self.c.model):
            result = self.rollout(self.c.optimizer.num_particles, 0.0, self.streams.reporting)
            costs = self.c.cost(result.states)
        states, costs_np = result.states.cpu().numpy(), costs.cpu().numpy()
        for observer in self.observers:
            if observer.wants_particles:
                observer.particles_predicted(trial, states, costs_np, self.c.system.dt)
        return states

    def _no_finite_step(self, trial: int, restarts: int) -> None:
        """The optimiser never saw a finite Ĵ: stop, naming where the particles (of the
        last policy tried, without dropout) first leave the finite numbers."""
        with torch.no_grad(), frozen(self.c.model):
            result = self.rollout(self.c.optimizer.num_particles, 0.0, self.streams.reporting)
        finite = torch.isfinite(result.states).all(dim=1).cpu().numpy()  # [T+1, d_x]
        where = "their cost is not finite although the states are"
        bad = np.argwhere(~finite)
        if bad.size:
            step, component = (int(i) for i in bad[0])
            names = self.c.system.state_names
            label = f" ({names[component]})" if component < len(names) else ""
            where = f"the particles first leave the finite numbers at step {step}, component "
            where += f"{component}{label}"
        raise NonFiniteError(
            f"trial {trial}: policy optimisation made no finite step ({restarts} policy "
            f"restarts); {where}: the model or the policy produces NaN/inf "
            f"({self._saved_note(trial)})"
        )

    def _interact(self, controller: Controller, trial: int) -> Trajectory:
        """Step 3: run a controller on the system from a fresh x0 ~ p(x0)."""
        system, rng = self.c.system, self.streams.system
        try:
            trajectory = system.rollout(
                controller, system.sample_initial_state(rng), system.num_steps, rng
            )
        except (NonFiniteError, SimulationError) as error:
            raise type(error)(f"trial {trial}, {error} ({self._saved_note(trial)})") from error
        self.trajectories.append(trajectory)
        return trajectory

    def _record(self, trial: int, trajectory: Trajectory, extra: dict[str, Any]) -> pd.DataFrame:
        """Store trial ``trial``'s rollout and summary row (``extra`` added to it); the row's
        ``logging_seconds`` includes the observers' time spent on the rollout here."""
        self.storage.save_trajectory(trial, trajectory)
        start = time.perf_counter()
        if self.observers:
            like = next(self.c.policy.parameters())
            with torch.no_grad():
                states = torch.as_tensor(trajectory.states, dtype=like.dtype, device=like.device)
                costs = self.c.cost(states).cpu().numpy()
            eval_costs = self.c.system.evaluation_cost(trajectory.states)
            for observer in self.observers:
                observer.rollout(trial, trajectory, costs, eval_costs)
        row: dict[str, Any] = {"trial": trial, **self.c.system.evaluate(trajectory), **extra}
        row["logging_seconds"] = row.get("logging_seconds", 0.0) + time.perf_counter() - start
        row["timestamp"] = time.time()
        # this process's time on the trial: a resumed run's pause is in no trial's figure
        row["trial_seconds"] = row["timestamp"] - self._trial_started
        self._trial_started = row["timestamp"]
        self.storage.save_random_state(trial, self.streams.state())
        # The log first (the MCAP chunk is flushed here), the summary row last: the row marks
        # the trial finished, so a kill between the two re-runs the trial on resume and the
        # log's copy of it is dropped then — a finished trial is never missing from the log.
        for observer in self.observers:
            observer.trial_finished(trial, row)
        table = self.storage.append_summary(row)
        log.info("%s", trial_line(row, self.num_trials))
        return table
