"""Particle predictions next to what the system did, from a run's MCAP log.

    python -m analysis.plot_run RUN_DIR [--trial K] [--out FIGURE.png] [--max-particles 100]

The thesis's Fig. 3.3 / 4.7 view: one panel per state component with the final policy's
particles on the learned model (grey), their mean (blue) and the real rollout (black); a
last panel with the training cost of the particles (mean) and of the real rollout.
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from mcpilco.errors import ConfigError  # noqa: E402
from mcpilco.safe_config import config_from_text, locate_class  # noqa: E402
from mcpilco.tracking import read_run_log  # noqa: E402
from mcpilco.tracking.reader import RunLog  # noqa: E402

log = logging.getLogger("mcpilco.plot_run")


def state_names(run_log: RunLog, dim: int, run_dir: Path | None = None) -> list[str]:
    """The logged system's state labels (from the config in the log's metadata; nothing
    inside ``run_dir``, the directory read, is imported)."""
    names: tuple[str, ...] = ()
    if run_log.metadata and "config" in run_log.metadata[0]:
        try:  # the class's labels; nothing is instantiated (see mcpilco.safe_config)
            config = config_from_text(run_log.metadata[0]["config"], "the log's metadata", run_dir)
            cls = locate_class(config.system._target_, "system._target_", run_dir)
            names = getattr(cls, "state_names", ())
        except (ConfigError, AttributeError) as error:
            log.warning("state labels unavailable (%s)", error)
    return list(names) if len(names) == dim else [f"x{i}" for i in range(dim)]


def plot_trial(
    run_log: RunLog, trial: int, max_particles: int = 100, run_dir: Path | None = None
) -> plt.Figure:
    rollout = run_log.rollout(trial)
    particles = run_log.particles[trial]
    times = rollout["time"].to_numpy()
    states = particles["states"]  # [T+1, M, d_x]
    dim = states.shape[2]
    figure, axes = plt.subplots(1, dim + 1, figsize=(3.2 * (dim + 1), 3.0), constrained_layout=True)
    names = state_names(run_log, dim, run_dir)
    for i in range(dim):
        ax = axes[i]
        ax.plot(times, states[:, :max_particles, i], color="0.6", linewidth=0.4, alpha=0.5)
        ax.plot(
            times, particles["mean"][:, i], color="tab:blue", linewidth=1.5, label="particle mean"
        )
        ax.plot(times, rollout[f"state_{i}"], color="black", linewidth=1.5, label="system")
        ax.set_title(names[i])
        ax.set_xlabel("time [s]")
    axes[0].legend(loc="best", fontsize=7)
    axes[-1].plot(times, particles["cost_mean"], color="tab:blue", label="particles (mean)")
    axes[-1].plot(times, rollout["cost"], color="black", label="system")
    axes[-1].set_title("training cost")
    axes[-1].set_xlabel("time [s]")
    axes[-1].legend(loc="best", fontsize=7)
    figure.suptitle(f"trial {trial}: {states.shape[1]} particles on the model vs the system")
    return figure


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("run_dir", type=Path)
    parser.add_argument("--trial", type=int, help="default: the last trial with particles")
    parser.add_argument("--out", type=Path, help="default: RUN_DIR/particles_trial_K.png")
    parser.add_argument("--max-particles", type=int, default=100)
    args = parser.parse_args()
    run_log = read_run_log(args.run_dir)
    if not run_log.particles:
        parser.error(f"{args.run_dir} holds no particle predictions yet")
    trial = args.trial if args.trial is not None else max(run_log.particles)
    if trial not in run_log.particles:
        parser.error(
            f"trial {trial} not logged; trials with particles: {sorted(run_log.particles)}"
        )
    out = args.out or args.run_dir / f"particles_trial_{trial}.png"
    figure = plot_trial(run_log, trial, args.max_particles, args.run_dir)
    figure.savefig(out, dpi=110)
    print(out)  # noqa: T201


if __name__ == "__main__":
    main()
