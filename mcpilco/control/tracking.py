"""Closed-loop reference tracking with a torque controller, and its metrics."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from mcpilco.control.controllers import TrackingController
from mcpilco.control.references import Reference
from mcpilco.control.robot import TorqueControlledRobot

DIVERGED_RAD = np.pi
"""A tracking error beyond this on any joint ends the run (the robot is out of control)."""


@dataclass
class TrackingRun:
    """One tracking run: ``time [T+1]`` (s); ``positions``, ``velocities``, ``reference``,
    ``errors`` ``[T+1, n]`` (rad, rad/s, rad, rad); ``torques [T, n]`` (N m, commanded by
    the controller); ``applied [T, n]`` (N m, after the robot's torque limits);
    ``latency [T]`` (s per controller call); ``diverged`` (stopped early, error > π)."""

    time: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    reference: np.ndarray
    errors: np.ndarray
    torques: np.ndarray
    applied: np.ndarray
    latency: np.ndarray
    diverged: bool

    def metrics(self, settle: float, threshold_deg: float = 1.0) -> dict[str, object]:
        """Per joint: max |e| after ``settle`` s (steady state) and RMS e, in degrees; max
        |τ| commanded; the share of steps the limits cut the command (per joint, and
        ``saturated_share``: any joint); success when the steady-state error is below
        ``threshold_deg`` on every joint for the whole run."""
        steady = self.errors[self.time >= settle]
        steady_max = (
            np.degrees(np.abs(steady).max(0))
            if len(steady)
            else np.full(self.errors.shape[1], np.inf)
        )
        cut = self.applied != self.torques  # [T, n]
        return {
            "steady_state_max_error_deg": steady_max.tolist(),
            "rms_error_deg": np.degrees(np.sqrt((self.errors**2).mean(0))).tolist(),
            "max_torque": np.abs(self.torques).max(0).tolist(),
            "saturated_share": float(cut.any(axis=1).mean()) if len(cut) else 0.0,
            "saturated_share_joint": cut.mean(0).tolist() if len(cut) else [0.0] * cut.shape[1],
            "diverged": self.diverged,
            "success": bool(not self.diverged and np.all(steady_max < threshold_deg)),
            "latency_median_ms": float(np.median(self.latency) * 1e3),
            "latency_p99_ms": float(np.percentile(self.latency, 99) * 1e3),
        }


def track(
    robot: TorqueControlledRobot,
    controller: TrackingController,
    reference: Reference,
    duration: float | None = None,
    initial_error: float = 0.0,
) -> TrackingRun:
    """Run ``controller`` for ``duration`` s (None: the reference's) from q0 = r(0) −
    ``initial_error`` (every joint; rad), q̇0 = ṙ(0); the robot applies each command
    within its torque limits; stop early if any |e| exceeds π."""
    n, dt = robot.num_joints, robot.dt
    steps = int(round((reference.duration if duration is None else duration) / dt))
    times = np.arange(steps + 1) * dt
    r, rd, rdd = reference(times)
    positions, velocities = np.empty((steps + 1, n)), np.empty((steps + 1, n))
    torques, latency = np.empty((steps, n)), np.empty(steps)
    positions[0], velocities[0] = r[0] - initial_error, rd[0]
    robot.reset(positions[0], velocities[0])
    last = steps
    for t in range(steps):
        start = time.perf_counter()
        torques[t] = controller(positions[t], velocities[t], (r[t], rd[t], rdd[t]))
        latency[t] = time.perf_counter() - start
        positions[t + 1], velocities[t + 1] = robot.step(torques[t])
        if np.abs(r[t + 1] - positions[t + 1]).max() > DIVERGED_RAD:
            last = t + 1
            break
    end = last + 1
    return TrackingRun(
        times[:end],
        positions[:end],
        velocities[:end],
        r[:end],
        r[:end] - positions[:end],
        torques[:last],
        robot.limited(torques[:last]),
        latency[:last],
        diverged=last < steps,
    )
