"""Latency of the torque controllers (``make bench``): one controller call per 1 kHz step.

The GP's cost per call depends on n and the kernel, not on the hyper-parameter values, so
the posterior is set on n samples of the real data-collection run with the kernels'
initial hyper-parameters (no ML-II: that takes minutes and changes nothing here).
"""

from __future__ import annotations

import time
from functools import partial

import numpy as np

from mcpilco.control import (
    GPFL,
    GPFLDCE,
    GPInverseDynamics,
    PyBulletArm,
    SineReference,
    TrueModelFL,
    collect,
)
from mcpilco.kernels import GeometricPolynomial, SquaredExponential


def call_latency(controller, robot, calls: int) -> tuple[float, float]:  # type: ignore[no-untyped-def]
    """(median, 99th percentile) seconds per controller call along a reference."""
    reference = SineReference.random(np.random.default_rng(0), robot.num_joints)
    times = np.arange(calls) * robot.dt
    r, rd, rdd = reference(times)
    q, qd = r[0].copy(), rd[0].copy()
    robot.reset(q, qd)
    latencies = np.empty(calls)
    for t in range(calls):
        start = time.perf_counter()
        torque = controller(q, qd, (r[t], rd[t], rdd[t]))
        latencies[t] = time.perf_counter() - start
        q, qd = robot.step(torque)
    return float(np.median(latencies)), float(np.percentile(latencies, 99))


def control_latencies(points: int = 5000, calls: int = 2000) -> dict[str, tuple[float, float]]:
    """Controller → (median, p99) seconds per call, GP controllers at ``points`` samples."""
    robot = PyBulletArm()
    duration = points * 10 * robot.dt  # the thesis's down-sampling by 10
    data = collect(
        robot,
        np.random.default_rng(0),
        duration=duration,
        reference_std=0.3,
        kp=[100, 200, 40, 60, 5, 5, 1],
        kd=[10, 20, 4, 6, 0.5, 0.5, 0.1],
    )
    results = {}
    true_fl = TrueModelFL()
    true_fl.bind(robot, None)
    results["true_fl"] = call_latency(true_fl, robot, calls)
    for name, kernel in (("se", SquaredExponential), ("gip", GeometricPolynomial)):
        model = GPInverseDynamics(partial(kernel), robot.num_joints, fit_points=None)
        model.condition(data)
        for label, controller in (("gp_fl", GPFL()), ("gp_fl_dce", GPFLDCE())):
            controller.bind(robot, model)
            results[f"{label} ({name.upper()}, n={len(data.positions)})"] = call_latency(
                controller, robot, calls
            )
    return results
