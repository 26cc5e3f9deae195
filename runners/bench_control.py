"""Latency of the torque controllers per 1 kHz call (``make bench``):

    python -m runners.bench_control [--points 5000] [--calls 2000] [--kernels se,gip]
        [--controllers true_fl,gp_fl,gp_fl_dce] [--dtypes float64,float32] [--threads 1]
        [--model-root DIR]

Each controller tracks a thesis reference (seed 0) on the PyBullet iiwa for ``--calls``
steps; the time of every controller call is measured and the median and 99th percentile
printed. The GP's cost per call depends on n and the kernel, not on the hyper-parameter
values, so by default the posterior is set on n samples of a data-collection run with the
kernels' initial hyper-parameters (no ML-II: minutes, and nothing changes here); with
``--model-root``, the fitted models ``DIR/<kernel>/gp.pt`` are loaded instead (their n).
"""

from __future__ import annotations

import argparse
import logging
import time
from functools import partial
from pathlib import Path

import numpy as np
import torch

from mcpilco.control import (
    GPFL,
    GPFLDCE,
    GPInverseDynamics,
    PyBulletArm,
    ThesisSines,
    TorqueControlledRobot,
    TrackingController,
    TrueModelFL,
    collect,
)
from mcpilco.errors import ConfigError
from mcpilco.kernels import GeometricPolynomial, SquaredExponential
from mcpilco.run_storage import load_tensors

log = logging.getLogger(__name__)
KERNELS = {"se": SquaredExponential, "gip": GeometricPolynomial}
CONTROLLERS = {"true_fl": TrueModelFL, "gp_fl": GPFL, "gp_fl_dce": GPFLDCE}


def call_latency(
    controller: TrackingController, robot: TorqueControlledRobot, calls: int
) -> tuple[float, float]:
    """(median, 99th percentile) seconds per controller call along a reference."""
    (reference,) = ThesisSines(seeds=[0]).references(robot.num_joints)
    r, rd, rdd = reference(np.arange(calls) * robot.dt)
    q, qd = r[0].copy(), rd[0].copy()
    robot.reset(q, qd)
    latencies = np.empty(calls)
    for t in range(calls):
        start = time.perf_counter()
        torque = controller(q, qd, (r[t], rd[t], rdd[t]))
        latencies[t] = time.perf_counter() - start
        q, qd = robot.step(torque)
    return float(np.median(latencies)), float(np.percentile(latencies, 99))


def gp_model(
    kernel: str, robot: PyBulletArm, points: int, model_root: Path | None
) -> GPInverseDynamics:
    """A GP of ``kernel``: fitted from ``model_root/<kernel>``, or conditioned on ``points``
    samples of a data-collection run with the initial hyper-parameters."""
    model = GPInverseDynamics(partial(KERNELS[kernel]), robot.num_joints, fit_points=None)
    if model_root is not None:
        model.load_state_dict(load_tensors(model_root / kernel / "gp.pt"))
        return model
    data = collect(
        robot,
        np.random.default_rng(0),
        duration=points * 10 * robot.dt,  # the thesis's down-sampling by 10
        reference_std=0.3,
        kp=[100, 200, 40, 60, 5, 5, 1],
        kd=[10, 20, 4, 6, 0.5, 0.5, 0.1],
    )
    model.condition(data)
    return model


def control_latencies(
    points: int = 5000,
    calls: int = 2000,
    kernels: tuple[str, ...] = ("se", "gip"),
    controllers: tuple[str, ...] = ("true_fl", "gp_fl", "gp_fl_dce"),
    dtypes: tuple[str, ...] = ("float64",),
    model_root: Path | None = None,
) -> dict[str, tuple[float, float]]:
    """Label → (median, p99) seconds per call."""
    robot = PyBulletArm()
    results: dict[str, tuple[float, float]] = {}
    if "true_fl" in controllers:
        reference = TrueModelFL()
        reference.bind(robot, None)
        results["true_fl"] = call_latency(reference, robot, calls)
    for kernel in kernels:
        model = gp_model(kernel, robot, points, model_root)
        size = model.gp.train_inputs.shape[0]
        for name in (c for c in controllers if c != "true_fl"):
            for dtype in dtypes:
                controller = CONTROLLERS[name](prediction_dtype=dtype)
                label = f"{name} ({kernel.upper()}, n={size}, {dtype})"
                try:
                    controller.bind(robot, model)
                except ConfigError as error:  # a precision this model does not allow
                    log.warning("%s: refused (%s)", label, error)
                    continue
                results[label] = call_latency(controller, robot, calls)
    return results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--points", type=int, default=5000, help="GP training points n")
    parser.add_argument("--calls", type=int, default=2000, help="controller calls timed")
    parser.add_argument("--kernels", default="se,gip", help="comma-separated: se, gip")
    parser.add_argument(
        "--controllers", default="true_fl,gp_fl,gp_fl_dce", help="true_fl, gp_fl, gp_fl_dce"
    )
    parser.add_argument("--dtypes", default="float64,float32", help="float64, float32")
    parser.add_argument("--threads", type=int, default=1, help="torch intra-op threads")
    parser.add_argument("--model-root", type=Path, default=None, help="DIR/<kernel>/gp.pt")
    args = parser.parse_args()
    choices = {
        "--kernels": (args.kernels, KERNELS),
        "--controllers": (args.controllers, CONTROLLERS),
        "--dtypes": (args.dtypes, ("float64", "float32")),
    }
    for flag, (value, allowed) in choices.items():
        for item in value.split(","):
            if item not in allowed:
                parser.error(f"{flag}={value!r}: {item!r} is not one of {', '.join(allowed)}")
    if args.points < 10 or args.calls < 100 or args.threads < 1:
        parser.error("--points must be >= 10, --calls >= 100, --threads >= 1")
    logging.basicConfig(level=logging.WARNING, format="  %(message)s")
    torch.set_num_threads(args.threads)
    print(  # noqa: T201
        f"controller latency per call, {args.calls} calls, torch {torch.__version__}, "
        f"{torch.get_num_threads()} thread(s)"
    )
    results = control_latencies(
        args.points,
        args.calls,
        tuple(args.kernels.split(",")),
        tuple(args.controllers.split(",")),
        tuple(args.dtypes.split(",")),
        args.model_root,
    )
    for label, (median, p99) in results.items():
        print(f"  {label:38s} median {median * 1e3:6.3f} ms  p99 {p99 * 1e3:6.3f} ms")  # noqa: T201


if __name__ == "__main__":
    main()
