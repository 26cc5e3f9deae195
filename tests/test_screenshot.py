"""The Rerun recording in the real web viewer: headless Chromium loads a small recording, the
viewer reports the blueprint's views on the ``time`` timeline, the PNG is not blank, and no
process is left behind. Skipped where no Chromium is installed."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from analysis.browser import find_chromium
from mcpilco.systems import CartPole
from mcpilco.tracking import RerunStreamer
from mcpilco.trajectory import Trajectory

try:
    find_chromium()
except FileNotFoundError:
    pytest.skip("no chromium binary (apt-get install chromium)", allow_module_level=True)

from analysis.screenshot import capture  # noqa: E402


def swing(steps: int, rng: np.random.Generator) -> np.ndarray:
    """A cart-pole state path ``[T+1, 4]``: the pole swinging up, the cart moving a little."""
    t = np.linspace(0.0, 1.0, steps + 1)
    return np.stack(
        [0.2 * np.sin(3 * t), 0.6 * np.cos(3 * t), np.pi * t**2, 2 * np.pi * t], axis=1
    ) + 0.01 * rng.standard_normal((steps + 1, 4))


def small_recording(run_dir: Path) -> Path:
    """Exploration (trial 0) and one learned trial through the live hooks, as a run does."""
    rng = np.random.default_rng(0)
    system = CartPole()
    streamer = RerunStreamer(
        run_dir, sketch=system.sketch, state_names=system.state_names, max_particles=20
    )
    streamer.run_started({"config": "system:\n  _target_: mcpilco.systems.CartPole\n"}, -1)
    steps, dt = 30, 0.05
    for trial in (0, 1):
        states = swing(steps, rng)
        trajectory = Trajectory(states, states.copy(), np.zeros((steps, 1)), dt)
        costs = 1.0 - np.exp(-((states[:, 2] - np.pi) ** 2))
        if trial == 1:
            trace = {k: list(np.linspace(1.0, 0.5, 10)) for k in ("cost", "dropout")}
            trace |= {k: [0.01] * 10 for k in ("learning_rate", "signal", "horizon")}
            streamer.optimized(trial, trace)
            predicted = 0.8 * states  # the model a little off the system
            particles = predicted[:, None, :] + 0.05 * rng.standard_normal((steps + 1, 40, 4))
            streamer.particles_predicted(trial, particles, costs[:, None].repeat(40, 1), dt)
        streamer.rollout(trial, trajectory, costs, costs)
        streamer.trial_finished(trial, {"coverage_p": 0.9, "coverage_mean": 0.9})
    streamer.close()
    return run_dir / "recording.rrd"


def viewer_processes() -> set[int]:
    """PIDs of processes this module starts (the viewer host and Chromium's profile)."""
    found = set()
    for cmdline in Path("/proc").glob("[0-9]*/cmdline"):
        try:
            text = cmdline.read_bytes().replace(b"\0", b" ")
        except OSError:
            continue
        if b"--serve-web" in text or b"mcpilco-chromium-" in text:
            found.add(int(cmdline.parent.name))
    return found


def test_viewer_lands_on_the_blueprint_and_the_screenshot_is_not_blank(tmp_path: Path) -> None:
    recording = small_recording(tmp_path)
    before = viewer_processes()
    # every view of the blueprint, 2 trials x 6 + 3 (under load the viewer can pause with
    # part of them shown for longer than the settle time)
    shot = capture(
        recording,
        tmp_path / "viewer.png",
        size=(1200, 700),
        timeout=120,
        ready=lambda state: len(state.views) >= 2 * 6 + 3,
    )

    state = shot.state
    assert state.current_timeline == "time"
    views = {(v.view_class, v.origin, v.name) for v in state.views}
    for trial in (0, 1):
        series = [v for v in state.views if v.origin == f"/trial_{trial}"]
        assert len(series) == 5 and {v.view_class for v in series} == {"TimeSeries"}
        assert {v.name.split(" (")[0] for v in series} >= {"x0 p [m]", "x3 θ̇ [rad/s]", "cost"}
        assert ("2D", f"/trial_{trial}/system", "system") in views
    assert ("TextDocument", "/run/config", "config") in views
    assert ("TimeSeries", "/optimization", "optimisation (timeline optimization_step)") in views
    assert len(state.views) == 2 * 6 + 3  # nothing the blueprint does not name

    png = shot.path.read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    assert struct.unpack(">II", png[16:24]) == (1200, 700)
    assert shot.grey_std > 10  # the loading page: 1.1 (a uniform dark grey)
    # the series were drawn: 0.003 and 0.002 of the pixels on a run, 1.3e-4 on the welcome page
    assert shot.system_pixels > 1e-3 and shot.mean_pixels > 1e-3
    assert viewer_processes() <= before  # the viewer host and Chromium are gone
