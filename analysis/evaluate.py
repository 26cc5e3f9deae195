"""Run a learned policy many times on the system and on its model, count the successes.

``python -m analysis.evaluate RUN_DIR [--trial K] [--runs 400] [--seed 0]``
``python -m analysis.evaluate RUN_DIR --trial K --episodes 10`` (``--episodes`` = ``--runs``)
``python -m analysis.evaluate RUN_DIR --starts 0=-2,-1.5,-1,-0.5,0,0.5,1,1.5,2``

Loads the run's config, the policy and GP checkpoints of trial K (default: the last
finished trial), then

* runs the policy ``--runs`` times on the system in closed loop (online estimator on the
  real readings, fresh x0 ~ p(x0) each time), and
* simulates ``--runs`` particles on the learned model the way the optimiser saw them
  (with or without the simulated online estimator, as the run was trained),

and applies the system's success criterion to every trajectory (thesis §3.3, Fig. 3.3);
every numeric metric is summarised by its mean, max and 95 % Student-t half-width over the
runs. A Gymnasium system (``system=gymnasium``) runs its environment's whole episode
(``max_episode_steps``, not the trial's length), so its ``env_return`` compares with
published returns; its starts are the environment's resets seeded from ``--seed``.
Writes ``evaluation/trial_KK.json`` in the run directory (the counts, each system run's
start and metrics, and their mean and max) and prints a summary.

With ``--starts INDEX=V1,V2,...`` it instead runs the policy once on the system from each
fixed start (p(x0)'s mean with state component INDEX set to each value, as in the thesis's
multimodal test, §2.6.2, Fig. 2.9) and writes ``evaluation/trial_KK_starts.json`` and a plot
of the trajectories (``.png``, ``.svg``).
"""

from __future__ import annotations

import argparse
import json
import logging
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tqdm import tqdm

from mcpilco.build import Experiment, build
from mcpilco.controller import PolicyController
from mcpilco.errors import CheckpointError, ConfigError, ForeignRunError, RunFileError
from mcpilco.optim.policy_optimizer import frozen
from mcpilco.optim.rollout import ParticleRollout
from mcpilco.run_contract import KINDS, READERS, TRAIN, recorded_kind
from mcpilco.run_storage import RunDirectory
from mcpilco.safe_config import load_run_config
from mcpilco.trajectory import Trajectory

log = logging.getLogger("mcpilco.evaluate")


def load_trial(run_dir: Path, trial: int | None) -> tuple[int, Experiment]:
    """The run's experiment built from its saved config, with trial ``trial``'s policy and
    GPs loaded (default: the last finished trial); a one-line exit on a trial it lacks."""
    if not (run_dir / "summary.csv").is_file():
        raise SystemExit(f"{run_dir} holds no summary.csv (not a run directory?)")
    try:
        kind = recorded_kind(run_dir, KINDS)
        if kind not in (TRAIN.name, None):
            raise SystemExit(
                f"{run_dir} holds a {kind} run, not a training run (read by "
                f"{READERS.get(str(kind), 'no mcpilco command')})"
            )
        storage = RunDirectory(run_dir)
        last = storage.finished_trials()
    except (ForeignRunError, RunFileError) as error:
        raise SystemExit(str(error)) from None
    trial = last if trial is None else trial
    if not 1 <= trial <= last:
        raise SystemExit(f"--trial={trial}: {run_dir} has learned trials 1..{last}")
    try:  # the saved config is checked before anything in it is built (mcpilco.safe_config)
        experiment = build(load_run_config(run_dir))
        experiment.components.policy.load_state_dict(storage.load_checkpoint(trial, "policy"))
        experiment.components.model.load_gp(storage.load_checkpoint(trial, "model"))
    except (ConfigError, CheckpointError) as error:
        raise SystemExit(str(error)) from None
    return trial, experiment


def evaluate(run_dir: Path, trial: int | None, runs: int, seed: int) -> dict[str, Any]:
    """Success counts of trial ``trial``'s policy on the system and on the model."""
    if runs < 1:
        raise SystemExit(f"--runs={runs} must be positive")
    trial, experiment = load_trial(run_dir, trial)
    c = experiment.components
    system, rng = c.system, np.random.default_rng(seed)

    steps = getattr(system, "episode_steps", None) or system.num_steps
    system_success, system_runs = [], []
    for _ in tqdm(range(runs), desc=f"trial {trial} on the system", unit="run"):
        controller = PolicyController(c.policy, c.model, c.estimator)
        x0 = system.sample_initial_state(rng)
        metrics = system.evaluate(system.rollout(controller, x0, steps, rng))
        system_success.append(metrics.get("success"))
        system_runs.append(
            {"initial_state": x0.tolist(), **{k: _plain(v) for k, v in metrics.items()}}
        )

    rollout = ParticleRollout.for_system(
        system, c.model, c.policy, c.cost, c.estimator, c.simulate_estimator
    )
    generator = torch.Generator(device=experiment.device).manual_seed(seed)
    with torch.no_grad(), frozen(c.model):
        particles = rollout(runs, 0.0, generator).states.cpu().numpy()  # [T+1, runs, d_x]
    no_actions = np.zeros((particles.shape[0] - 1, system.action_dim))
    model_success = [
        system.evaluate(Trajectory(states, states, no_actions, system.dt)).get("success")
        for states in particles.transpose(1, 0, 2)
    ]
    result = {
        "trial": trial,
        "runs": runs,
        "steps": steps,
        "seed": seed,
        "simulate_estimator": c.simulate_estimator,
        "success_criterion": has_criterion(system_success),
        "system_successes": count_successes(system_success),
        "model_successes": count_successes(model_success),
        "system_metrics": summarise_metrics(system_runs),
        "system_runs": system_runs,
    }
    RunDirectory(run_dir).write_text(
        f"evaluation/trial_{trial:02d}.json", json.dumps(result, indent=2)
    )
    return result


def has_criterion(outcomes: list[Any]) -> bool:
    """Whether the system's ``evaluate`` reports a ``success`` (not every system has a
    success criterion, e.g. a user's plug-in)."""
    return all(outcome is not None for outcome in outcomes)


def count_successes(outcomes: list[Any]) -> int | None:
    """Number of successes, None when the system has no success criterion."""
    return int(sum(bool(o) for o in outcomes)) if has_criterion(outcomes) else None


def summarise_metrics(runs: list[dict[str, Any]]) -> dict[str, dict[str, float]]:
    """Mean, max and the 95 % Student-t half-width of the mean (``ci95``, NaN for one run)
    over runs of every numeric (non-boolean) metric the system reports."""
    from scipy import stats

    names = [
        k for k, v in runs[0].items() if isinstance(v, int | float) and not isinstance(v, bool)
    ]
    summary = {}
    for name in names:
        values = np.array([run[name] for run in runs], dtype=np.float64)
        half = (
            float(stats.t.ppf(0.975, len(values) - 1) * values.std(ddof=1) / np.sqrt(len(values)))
            if len(values) > 1
            else float("nan")
        )
        summary[name] = {"mean": float(values.mean()), "max": float(values.max()), "ci95": half}
    return summary


def parse_starts(text: str, state_dim: int) -> tuple[int, list[float]]:
    """``"INDEX=V1,V2,..."`` → (state index, values); a one-line error otherwise."""
    index_text, _, values_text = text.partition("=")
    try:
        index = int(index_text)
        values = [float(v) for v in values_text.split(",") if v.strip()]
    except ValueError:
        raise SystemExit(f"--starts={text!r} must read INDEX=V1,V2,... (numbers)") from None
    if not 0 <= index < state_dim or not values:
        raise SystemExit(f"--starts={text!r}: INDEX in 0..{state_dim - 1} and at least one value")
    return index, values


def evaluate_starts(run_dir: Path, trial: int | None, starts: str, seed: int) -> dict[str, Any]:
    """One system run of trial ``trial``'s policy from each fixed start; success per start."""
    trial, experiment = load_trial(run_dir, trial)
    c = experiment.components
    index, values = parse_starts(starts, c.system.state_dim)
    rng = np.random.default_rng(seed)
    trajectories, outcomes = [], []
    for value in values:
        x0 = c.system.initial_mean.copy()
        x0[index] = value
        controller = PolicyController(c.policy, c.model, c.estimator)
        trajectory = c.system.rollout(controller, x0, c.system.num_steps, rng)
        metrics = c.system.evaluate(trajectory)
        trajectories.append(trajectory)
        outcomes.append(
            {
                "start": value,
                "initial_state": x0.tolist(),
                **{k: _plain(v) for k, v in metrics.items()},
            }
        )
    result = {"trial": trial, "seed": seed, "component": index, "starts": outcomes}
    name = f"evaluation/trial_{trial:02d}_starts"
    RunDirectory(run_dir).write_text(f"{name}.json", json.dumps(result, indent=2))
    _plot_starts(run_dir / name, c.system, trajectories, values, index)
    return result


def _plain(value: Any) -> Any:
    """numpy scalars → Python numbers (JSON)."""
    return value.item() if isinstance(value, np.generic) else value


def _plot_starts(
    stem: Path, system: Any, trajectories: list[Trajectory], values: list[float], index: int
) -> None:
    """Every state component over time, one line per start (PNG and SVG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(system.state_names) or [f"x{i}" for i in range(system.state_dim)]
    figure, axes = plt.subplots(1, system.state_dim, figsize=(3.2 * system.state_dim, 3))
    colours = plt.get_cmap("viridis")(np.linspace(0, 1, len(values)))
    for trajectory, value, colour in zip(trajectories, values, colours, strict=True):
        time_axis = np.arange(trajectory.states.shape[0]) * trajectory.dt
        for component, axis in enumerate(axes):
            axis.plot(
                time_axis, trajectory.states[:, component], color=colour, lw=1.2, label=f"{value:g}"
            )
    for component, axis in enumerate(axes):
        axis.set_xlabel("t [s]")
        axis.set_title(names[component])
    axes[0].legend(title=f"start {names[index]}", fontsize=7)
    figure.tight_layout()
    for suffix in (".png", ".svg"):
        figure.savefig(stem.with_suffix(suffix), dpi=120)
    plt.close(figure)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("run_dir", type=Path)
    parser.add_argument("--trial", type=int, default=None, help="default: last finished")
    parser.add_argument("--runs", "--episodes", dest="runs", type=int, default=400)
    parser.add_argument("--seed", type=int, default=0, help="x0, noise and particle seed")
    parser.add_argument("--starts", default=None, help="INDEX=V1,V2,...: one run per start")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)
    if args.starts is not None:
        outcome = evaluate_starts(args.run_dir, args.trial, args.starts, args.seed)
        outcomes = [s.get("success") for s in outcome["starts"]]
        wins = count_successes(outcomes)
        print(  # noqa: T201
            f"trial {outcome['trial']}: {wins}/{len(outcomes)} starts succeed"
            if wins is not None
            else f"trial {outcome['trial']}: {len(outcomes)} starts run (the system has no "
            "success criterion; see the JSON for its metrics)"
        )
        return
    result = evaluate(args.run_dir, args.trial, args.runs, args.seed)
    if result["success_criterion"]:
        print(  # noqa: T201
            f"trial {result['trial']}: system {result['system_successes']}/{result['runs']}, "
            f"model {result['model_successes']}/{result['runs']} successes"
        )
    else:
        print(  # noqa: T201
            f"trial {result['trial']}: {result['runs']} runs on the system; no success count "
            "(the system's evaluate() reports no 'success')"
        )
    for name, stats in result["system_metrics"].items():
        print(  # noqa: T201
            f"  system {name}: mean {stats['mean']:.4g} ± {stats['ci95']:.3g} (95 %), "
            f"max {stats['max']:.4g}"
        )


if __name__ == "__main__":
    main()
