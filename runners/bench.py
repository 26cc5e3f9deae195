"""Performance figures: ``make bench`` (or ``python -m runners.bench``).

Prints, for one policy-optimisation step (particle rollout + backward + Adam) of the
cart-pole speed-integration SE model at M=400, T=60, n_b=200: the median wall time over
``--steps`` steps after warm-up for n = 60 and n = 300 training points in float64, float32
and the mixed setting (float64 GP, float32 rollout), eager and compiled, float64 compiled
with ``model.gp.forward_gradient=false`` (autograd), and again compiled with one thread
when torch has more; the rollout's achieved GFLOP/s (flops counted
analytically from the dominant products, see :func:`rollout_flops`), the machine's own
float64 matmul GFLOP/s measured in the same run, the GP fit time at n = 300 against the
reference recipe (1500 full-batch Adam steps at learning rate 0.01), the per-call latency
of the torque controllers of ``runners.control`` at n = 5000 (:mod:`runners.bench_control`),
and the wall time of a whole ``protocol=quick`` cart-pole run per phase (``--skip-run``
leaves it out: it takes minutes). ``make bench-trial`` times trial 1 at thesis settings.
"""

from __future__ import annotations

import argparse
import logging
import statistics
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from hydra import compose, initialize_config_dir

from mcpilco.build import Experiment, build
from mcpilco.errors import NotPositiveDefiniteError
from mcpilco.optim.policy_optimizer import frozen
from mcpilco.optim.rollout import ParticleRollout
from runners.bench_control import control_latencies
from runners.bench_run import logging_overhead, whole_run
from runners.process import keep_freed_memory

CONFIG_DIR = str(Path(__file__).resolve().parent.parent / "conf")
log = logging.getLogger("mcpilco.bench")


def matmul_gflops(size: int = 1000, repeats: int = 10) -> float:
    """Best-of float64 GEMM throughput of this machine (GFLOP/s)."""
    a = torch.randn(size, size, dtype=torch.float64)
    b = torch.randn(size, size, dtype=torch.float64)
    a @ b
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        a @ b
        best = min(best, time.perf_counter() - start)
    return 2.0 * size**3 / best / 1e9


def rollout_flops(
    particles: int, horizon: int, n: int, outputs: int, gp_dim: int, basis: int, policy_dim: int
) -> float:
    """Floating-point operations of one rollout + backward, dominant products only.

    Per step, forward: kernel 2GMND, k*Γ⁻¹ 2GMN², mean 2GMN, quadratic 2GMN, policy
    distances 2M n_b d + output 2M n_b; backward: kernel 2GMND, policy 3 products of
    2M n_b d. Element-wise work (exp, masks) is not counted.
    """
    g, m = outputs, particles
    forward = 2 * g * m * n * gp_dim + 2 * g * m * n * n + 4 * g * m * n
    forward += 2 * m * basis * policy_dim + 2 * m * basis
    backward = 2 * g * m * n * gp_dim + 3 * 2 * m * basis * policy_dim + 2 * g * m * n
    return float(horizon * (forward + backward))


def exploration_data(experiment, n: int, seed: int = 0):  # type: ignore[no-untyped-def]
    system = experiment.components.system
    rng = np.random.default_rng(seed)
    trajectories = []
    while sum(t.num_steps for t in trajectories) < n:
        controller = experiment.components.exploration(rng=rng)
        trajectories.append(
            system.rollout(controller, system.sample_initial_state(rng), system.num_steps, rng)
        )
    estimator = experiment.components.estimator  # offline estimates, as the trial loop fits
    states = [estimator.offline(t.measurements, system.dt, t.actions) for t in trajectories]
    actions = [t.actions for t in trajectories]
    return states, actions


def fitted_experiment(overrides: Sequence[str], n: int) -> Experiment:
    """The ``train`` experiment with ``overrides``, its model fitted to exactly ``n``
    exploration points (seed 0, trimmed when the last rollout overshoots) and its
    prediction cache built: the starting point of every step timing and step study."""
    with initialize_config_dir(version_base="1.3", config_dir=CONFIG_DIR):
        cfg = compose("train", overrides=list(overrides))
    experiment = build(cfg)
    model = experiment.components.model
    model.fit(*exploration_data(experiment, n))
    assert model.gp is not None
    if model.gp.train_inputs.shape[0] != n:
        model.gp.set_data(model.gp.train_inputs[:n], model.gp.train_targets[:n])
        model.gp.precompute()
    return experiment


def synchronize(device: str) -> None:
    """Wait for queued GPU work, so that wall-clock readings cover it."""
    if device.startswith("cuda"):
        torch.cuda.synchronize(device)


CARTPOLE = ("kernel=se", "model=speed_integration")
"""The cart-pole setting of the step figures (M 400, T 60, n_b 200)."""
AUTOGRAD = "model.gp.forward_gradient=false"
"""GP samples' gradient through autograd, the default before the forward-pass form
(``docs/results/forward_gradient/``)."""
UR5 = ("+experiment=ur5", "model.reduction_threshold=null")
"""The UR5 setting (thesis §2.6.3: M 200, T 200, n_b 400, 6 GP outputs, SE + linear)."""


@dataclass(frozen=True)
class StepTiming:
    """Median seconds per optimisation step, achieved GFLOP/s, seconds of one
    gradient-free rollout (what the loggers' particle prediction costs), and seconds of
    the warm-up steps (with ``compile``: compiling the graphs)."""

    median: float
    gflops: float
    prediction: float
    warmup: float


def time_steps(
    dtype: str,
    n: int,
    steps: int,
    warmup: int,
    device: str = "cpu",
    setting: tuple[str, ...] = CARTPOLE,
    compile: bool = False,
) -> StepTiming:
    """Time ``steps`` optimisation steps after ``warmup`` untimed ones; ``dtype`` is
    ``float64``, ``float32`` or ``mixed`` (float64 GP, float32 rollout)."""
    dtypes = (  # every row names both keys: the defaults do not decide what a row measures
        ["dtype=float64", "rollout_dtype=float32"]
        if dtype == "mixed"
        else [f"dtype={dtype}", "rollout_dtype=null"]
    )
    overrides = [*dtypes, *setting, f"device={device}", f"compile={compile}"]
    experiment = fitted_experiment(overrides, n)
    c = experiment.components
    rollout = ParticleRollout.for_system(
        c.system,
        c.model,
        c.policy,
        c.cost,
        c.estimator,
        compile=compile,
        dtype=c.rollout_dtype,
        compile_steps=c.compile_steps,
    )
    optimizer = torch.optim.Adam(c.policy.parameters(), lr=0.01)
    particles = c.optimizer.num_particles
    times, warmup_seconds = [], 0.0
    started = time.perf_counter()
    with frozen(c.model):
        for step in range(warmup + steps):
            synchronize(device)
            start = time.perf_counter()
            optimizer.zero_grad(set_to_none=True)
            rollout(particles, 0.25, experiment.streams.particles).total_cost.backward()
            optimizer.step()
            synchronize(device)
            if step >= warmup:
                times.append(time.perf_counter() - start)
            elif step == warmup - 1:
                warmup_seconds = time.perf_counter() - started
    with torch.no_grad(), frozen(c.model):
        synchronize(device)
        start = time.perf_counter()
        rollout(particles, 0.0, experiment.streams.particles)
        synchronize(device)
        prediction = time.perf_counter() - start
    median = statistics.median(times)
    flops = rollout_flops(
        particles,
        c.system.num_steps,
        n,
        c.model.num_outputs,
        c.model.gp_input_dim,
        c.policy.num_basis,
        c.model.policy_input_size,
    )
    return StepTiming(median, flops / median / 1e9, prediction, warmup_seconds)


def fit_comparison(n: int = 300, setting: tuple[str, ...] = CARTPOLE) -> dict[str, float]:
    """Our L-BFGS fit against 1500 full-batch Adam steps at lr 0.01 (reference recipe)."""
    with initialize_config_dir(version_base="1.3", config_dir=CONFIG_DIR):
        cfg = compose("train", overrides=list(setting))
    experiment = build(cfg)
    model = experiment.components.model
    states, actions = exploration_data(experiment, n)
    start = time.perf_counter()
    report = model.fit(states, actions)
    ours = time.perf_counter() - start
    assert model.gp is not None
    reference = model.new_gp()
    reference.set_data(model.gp.train_inputs, model.gp.train_targets)
    adam = torch.optim.Adam([p for p in reference.parameters() if p.requires_grad], lr=0.01)
    start = time.perf_counter()
    for _ in range(1500):
        adam.zero_grad()
        loss = reference.negative_log_marginal_likelihood()
        loss.backward()
        adam.step()
    adam_seconds = time.perf_counter() - start
    with torch.no_grad():
        adam_nll = float(reference.negative_log_marginal_likelihood())
    return {
        "lbfgs_seconds": ours,
        "lbfgs_nll_per_point": report.negative_log_likelihood,
        "adam_seconds": adam_seconds,
        "adam_nll_per_point": adam_nll,
    }


def print_fit(label: str, fit: dict[str, float]) -> None:
    print(  # noqa: T201
        f"{label}: L-BFGS {fit['lbfgs_seconds']:.2f} s, -log p/N "
        f"{fit['lbfgs_nll_per_point']:.4f}; 1500 Adam steps lr 0.01: "
        f"{fit['adam_seconds']:.2f} s, -log p/N {fit['adam_nll_per_point']:.4f}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--steps", type=int, default=15, help="timed steps per setting")
    parser.add_argument("--warmup", type=int, default=3, help="untimed steps first")
    parser.add_argument("--threads", type=int, default=None, help="torch threads")
    parser.add_argument("--skip-fit", action="store_true", help="skip the GP fit comparison")
    parser.add_argument("--device", default="cpu", help="cpu | cuda | cuda:K (the step timings)")
    parser.add_argument(
        "--skip-run", action="store_true", help="skip the whole quick-protocol run (minutes)"
    )
    parser.add_argument("--skip-ur5", action="store_true", help="skip the UR5 step and fit")
    parser.add_argument(
        "--skip-control", action="store_true", help="skip the torque-controller latencies"
    )
    args = parser.parse_args()
    keep_freed_memory()
    if args.threads:
        torch.set_num_threads(args.threads)
    logging.basicConfig(level=logging.WARNING)
    print(f"torch {torch.__version__}, threads {torch.get_num_threads()}")  # noqa: T201
    print(f"machine float64 matmul: {matmul_gflops():.1f} GFLOP/s")  # noqa: T201
    print(  # noqa: T201
        f"policy-optimisation step on {args.device}, M=400 T=60 n_b=200, speed-integration SE:"
    )
    timings = {}
    for n in (60, 300):
        for dtype in ("float64", "float32", "mixed"):
            for compiled in (False, True):
                timing = time_steps(
                    dtype, n, args.steps, args.warmup, args.device, compile=compiled
                )
                timings[n, dtype, compiled] = timing
                mode = f"compiled (warm-up {timing.warmup:4.1f} s)" if compiled else "eager"
                print(  # noqa: T201
                    f"  n={n:3d} {dtype:7s}: median {timing.median * 1e3:7.1f} ms/step over "
                    f"{args.steps} steps, rollout {timing.gflops:5.2f} GFLOP/s, {mode}"
                )
    print("float64 with model.gp.forward_gradient=false (autograd), compiled:")  # noqa: T201
    for n in (60, 300):
        setting = (*CARTPOLE, AUTOGRAD)
        timing = time_steps("float64", n, args.steps, args.warmup, args.device, setting, True)
        print(  # noqa: T201
            f"  n={n:3d} float64: median {timing.median * 1e3:7.1f} ms/step over "
            f"{args.steps} steps, rollout {timing.gflops:5.2f} GFLOP/s, compiled"
        )
    threads = torch.get_num_threads()
    if threads > 1 and args.device == "cpu":
        torch.set_num_threads(1)
        print("the same with one thread (as a sweep's jobs run), compiled:")  # noqa: T201
        for n in (60, 300):
            for dtype in ("float64", "float32", "mixed"):
                timing = time_steps(dtype, n, args.steps, args.warmup, compile=True)
                print(  # noqa: T201
                    f"  n={n:3d} {dtype:7s}: median {timing.median * 1e3:7.1f} ms/step, 1 thread"
                )
        torch.set_num_threads(threads)
    print(f"machine float64 matmul (again): {matmul_gflops():.1f} GFLOP/s")  # noqa: T201
    reference = timings[60, "float64", True]
    overhead, fraction = logging_overhead(reference.median, reference.prediction)
    print(  # noqa: T201
        f"logging (MCAP + Rerun) per trial of 1500 steps: {overhead:.2f} s = "
        f"{100 * fraction:.2f}% of its optimisation time at n=60 float64 compiled"
    )
    if not args.skip_fit:
        print_fit("GP fit n=300", fit_comparison())
    if not args.skip_ur5:
        print("UR5 step, M=200 T=200 n_b=400, speed-integration SE+linear, 6 GPs:")  # noqa: T201
        for dtype in ("float64", "float32"):
            try:
                timing = time_steps(dtype, 400, 3, 1, args.device, UR5, compile=True)
            except NotPositiveDefiniteError as error:  # measured: float32 UR5 fits can fail
                print(f"  n=400 {dtype}: no GP fit ({error})")  # noqa: T201
                continue
            print(  # noqa: T201
                f"  n=400 {dtype}: median {timing.median * 1e3:7.1f} ms/step over 3 steps, "
                f"rollout {timing.gflops:5.2f} GFLOP/s, compiled"
            )
        if not args.skip_fit:
            print_fit("UR5 GP fit n=400", fit_comparison(400, UR5))
    if not args.skip_control:
        print("torque controllers, per 1 kHz call (target p99 < 1 ms):")  # noqa: T201
        for name, (median, p99) in control_latencies(dtypes=("float64", "float32")).items():
            print(f"  {name}: median {median * 1e3:.3f} ms, p99 {p99 * 1e3:.3f} ms")  # noqa: T201
    if not args.skip_run:
        phases = whole_run(args.threads)
        print(  # noqa: T201
            "whole protocol=quick cart-pole run (5 trials): "
            + ", ".join(f"{name} {seconds:.1f} s" for name, seconds in phases.items())
        )


if __name__ == "__main__":
    main()
