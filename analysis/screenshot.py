"""Render a run's Rerun recording in the real web viewer (headless Chromium) and save a PNG.

    python -m analysis.screenshot RUN_DIR_OR_RRD [--out FILE.png] [--size 1600x900]

The recording (a run directory's ``recording.rrd``; else its ``replay.rrd``, rebuilt from
``rollouts.mcap`` by ``runners.replay`` when missing) is served over HTTP with CORS, the web
viewer by ``rerun --serve-web`` (which then only hosts the viewer's files), and Chromium loads
it headless, WebGL2 through its software renderer. A DevTools-protocol client waits until the
viewer reports the recording's views (``WebHandle.viewer_state()``), then captures the page.
Everything binds to 127.0.0.1, and every process started is stopped on the way out.
"""

from __future__ import annotations

import argparse
import base64
import io
import logging
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import quote

import numpy as np

from analysis.browser import Chromium, DevTools, RecordingServer, WebViewer, find_chromium
from analysis.viewer_state import ViewerState, decode_viewer_state
from mcpilco.tracking.rerun_stream import STYLES, recording_parts

log = logging.getLogger("mcpilco.screenshot")

READ_STATE = """(() => {
  const h = window._handle;
  if (!h) return null;
  if (h.has_panicked()) return "panic:" + h.panic_message();
  let s = "";
  for (const b of h.viewer_state()) s += String.fromCharCode(b);
  return btoa(s);
})()"""


@dataclass(frozen=True)
class Screenshot:
    """A captured viewer: the PNG's path, what the viewer reported, the seconds from
    navigation until the views were there, the image's grey-level standard deviation, and
    the fraction of its pixels in the colour of the system's series and of the particles'
    mean (``mcpilco.tracking.rerun_stream.STYLES``): ~1e-4 where no series is drawn."""

    path: Path
    state: ViewerState
    seconds_to_views: float
    grey_std: float
    system_pixels: float
    mean_pixels: float


def find_recording(path: Path) -> list[Path]:
    """The ``.rrd`` files to show for ``path``: the file itself; for a run directory, the
    parts of its live recording (``recording.rrd``, ``recording.1.rrd`` after a resume, ...),
    else ``replay.rrd``, rebuilt from the MCAP log when missing."""
    if path.is_file():
        return [path]
    if not path.is_dir():
        raise FileNotFoundError(f"{path} is neither a recording nor a run directory")
    parts = recording_parts(path)
    if parts:
        return parts
    if not (path / "replay.rrd").is_file():
        from runners.replay import main as replay

        if replay([str(path)]) != 0:
            raise FileNotFoundError(f"{path} has no recording and its MCAP log cannot be replayed")
    return [path / "replay.rrd"]


def rgb(png: bytes) -> np.ndarray:
    """The PNG's pixels ``[H, W, 3]``, 0..255."""
    from matplotlib import image

    return np.asarray(image.imread(io.BytesIO(png), format="png"))[..., :3] * 255.0


def grey_std(png: bytes) -> float:
    """Standard deviation of the grey level (0..255) of a PNG image: ~0 for a blank page."""
    return float(rgb(png).mean(axis=-1).std())


def colour_fraction(png: bytes, colour: tuple[int, ...], tolerance: float = 30.0) -> float:
    """Fraction of the pixels within ``tolerance`` (per channel, 0..255) of ``colour``."""
    distance = np.abs(rgb(png) - np.asarray(colour[:3], dtype=float)).max(axis=-1)
    return float((distance <= tolerance).mean())


def wait_for_views(
    devtools: DevTools,
    timeout: float,
    settle: float = 1.5,
    ready: Callable[[ViewerState], bool] | None = None,
) -> ViewerState:
    """Poll the viewer until it shows views on a recording with a ``time`` timeline, the
    state has not changed for ``settle`` seconds and ``ready(state)`` holds (when given: e.g.
    every view a caller expects; on a starved CPU the viewer can pause for ``settle`` with
    part of the blueprint's views shown).

    Raises:
        RuntimeError: the viewer panicked.
        TimeoutError: no such state within ``timeout`` seconds.
    """
    deadline = time.monotonic() + timeout
    last: ViewerState | None = None
    stable_since = time.monotonic()
    while time.monotonic() < deadline:
        encoded = devtools.evaluate(READ_STATE)
        if isinstance(encoded, str) and encoded.startswith("panic:"):
            raise RuntimeError(f"the Rerun viewer crashed: {encoded[6:300]}")
        state = decode_viewer_state(base64.b64decode(encoded)) if encoded else None
        if state is None or state != last:
            last, stable_since = state, time.monotonic()
        elif state.views and "time" in state.timelines and (ready is None or ready(state)):
            if time.monotonic() - stable_since >= settle:
                return state
        time.sleep(0.25)
    raise TimeoutError(f"the viewer showed no views within {timeout:.0f} s (last state: {last})")


def capture(
    recording: Path | list[Path],
    out: Path,
    size: tuple[int, int] = (1600, 900),
    timeout: float = 120.0,
    render_seconds: float = 3.0,
    ready: Callable[[ViewerState], bool] | None = None,
) -> Screenshot:
    """Show ``recording`` in the web viewer and write the page as a PNG to ``out``.

    Args:
        recording: an ``.rrd`` file, or the parts of one recording (shown together).
        out: the PNG to write.
        size: the browser window (pixels, width × height).
        timeout: seconds allowed for the viewer to load the recording and show its views.
        render_seconds: extra seconds for the software renderer to draw the plots.
        ready: what the viewer's state must show before the picture is taken (None: any
            views on a ``time`` timeline, stable for 1.5 s; see :func:`wait_for_views`).
    """
    chromium = find_chromium()
    with (
        RecordingServer(recording) as file_urls,
        WebViewer(file_urls) as viewer_url,
        Chromium(chromium, size) as browser,
        DevTools(browser.page_websocket()) as devtools,
    ):
        started = time.monotonic()
        query = "&".join(f"url={quote(url, safe='')}" for url in file_urls)
        devtools.navigate(f"{viewer_url}/?{query}&persist=0", size)
        state = wait_for_views(devtools, timeout, ready=ready)
        seconds = time.monotonic() - started
        time.sleep(render_seconds)
        png = devtools.screenshot()
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_bytes(png)
    return Screenshot(
        out, state, seconds, grey_std(png),
        colour_fraction(png, STYLES["real"][0]), colour_fraction(png, STYLES["mean"][0]),
    )  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("path", type=Path, help="a run directory or an .rrd recording")
    parser.add_argument("--out", type=Path, help="PNG to write (default: RUN/viewer.png)")
    parser.add_argument("--size", default="1600x900", help="window WIDTHxHEIGHT in pixels")
    parser.add_argument("--timeout", type=float, default=120.0, help="seconds to load")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(message)s")
    try:
        width, height = (int(v) for v in args.size.lower().split("x"))
    except ValueError:
        log.error("--size=%r must be WIDTHxHEIGHT, e.g. 1600x900", args.size)
        return 2
    try:
        recording = find_recording(args.path)
        out = args.out or recording[0].with_name("viewer.png")
        shot = capture(recording, out, (width, height), args.timeout)
    except (FileNotFoundError, RuntimeError, TimeoutError) as error:
        log.error("%s", error)
        return 2
    log.info(
        "%s: %d views on timeline %r after %.1f s (viewer %s); grey-level std %.1f; "
        "pixels in the system's / the mean's colour %.4f / %.4f",
        shot.path, len(shot.state.views), shot.state.current_timeline, shot.seconds_to_views,
        shot.state.viewer_version, shot.grey_std, shot.system_pixels, shot.mean_pixels,
    )  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
