"""The processes behind ``analysis.screenshot``, each a context manager that stops what it
started: a one-file HTTP server, Rerun's web-viewer host, headless Chromium, and a minimal
client of the Chrome DevTools protocol. All of them listen on 127.0.0.1 only."""

from __future__ import annotations

import base64
import functools
import itertools
import json
import logging
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from types import TracebackType
from typing import Any
from urllib.parse import quote

from websockets.sync.client import ClientConnection, connect

log = logging.getLogger("mcpilco.screenshot")
LOCALHOST = "127.0.0.1"
CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


def find_chromium() -> str:
    """The path of a Chromium/Chrome binary on ``PATH``.

    Raises:
        FileNotFoundError: none is installed (Debian: ``apt-get install chromium``).
    """
    for name in CHROMIUM_NAMES:
        found = shutil.which(name)
        if found:
            return found
    raise FileNotFoundError(
        f"no Chromium found on PATH (looked for {', '.join(CHROMIUM_NAMES)}); "
        "on Debian/Ubuntu: apt-get install chromium"
    )


def stop_group(process: subprocess.Popen[Any], grace: float = 5.0) -> None:
    """Terminate ``process`` and its process group (started with ``start_new_session``)."""
    if process.poll() is not None:
        return
    for sig in (signal.SIGTERM, signal.SIGKILL):
        try:
            os.killpg(process.pid, sig)
        except ProcessLookupError:
            return
        try:
            process.wait(grace)
            return
        except subprocess.TimeoutExpired:
            continue


class _GivenFiles(BaseHTTPRequestHandler):
    """Serves the given files, the k-th at ``/<k>/<its name>``, with CORS; nothing else."""

    def __init__(self, *args: Any, files: list[Path], **kwargs: Any) -> None:
        self.files = {file_url_path(k, f): f for k, f in enumerate(files)}
        super().__init__(*args, **kwargs)

    def _head(self) -> Path | None:
        file = self.files.get(self.path.split("?")[0])
        if file is None:
            self.send_error(404)
            return None
        self.send_response(200)
        self.send_header("Content-Type", "application/octet-stream")
        self.send_header("Content-Length", str(file.stat().st_size))
        self.send_header("Access-Control-Allow-Origin", "*")
        self.end_headers()
        return file

    def do_HEAD(self) -> None:  # noqa: N802 (the http.server interface)
        self._head()

    def do_GET(self) -> None:  # noqa: N802
        file = self._head()
        if file is not None:
            with file.open("rb") as source:
                shutil.copyfileobj(source, self.wfile)

    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002
        log.debug("recording server: " + format, *args)


def file_url_path(index: int, file: Path) -> str:
    return f"/{index}/{quote(file.name)}"


class RecordingServer:
    """Serves ``files`` on 127.0.0.1 (a free port) while the context is open; yields their
    URLs."""

    def __init__(self, files: Path | list[Path]) -> None:
        self.files = [f.resolve() for f in ([files] if isinstance(files, Path) else files)]
        handler = functools.partial(_GivenFiles, files=self.files)
        self.server = ThreadingHTTPServer((LOCALHOST, 0), handler)
        self.thread = threading.Thread(target=self.server.serve_forever, daemon=True)

    def __enter__(self) -> list[str]:
        self.thread.start()
        root = f"http://{LOCALHOST}:{self.server.server_address[1]}"
        return [root + file_url_path(k, f) for k, f in enumerate(self.files)]

    def __exit__(self, *exc: object) -> None:
        self.server.shutdown()
        self.server.server_close()
        self.thread.join()


class WebViewer:
    """``rerun --serve-web`` on 127.0.0.1 (a free port) for recording URLs; yields the
    viewer's URL. Given URLs to show, rerun hosts only the viewer's files (no gRPC proxy)."""

    def __init__(self, recording_urls: list[str], startup: float = 30.0) -> None:
        self.recording_urls = recording_urls
        self.startup = startup
        self.process: subprocess.Popen[str] | None = None

    def __enter__(self) -> str:
        rerun = Path(sys.executable).parent / "rerun"
        command = [str(rerun) if rerun.exists() else "rerun", "--serve-web", "--bind", LOCALHOST]
        command += ["--web-viewer-port", "0", *self.recording_urls]
        self.process = subprocess.Popen(
            command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
            start_new_session=True,
        )  # fmt: skip
        found: list[str] = []
        ready = threading.Event()

        def read() -> None:  # keeps draining the pipe so that rerun never blocks on it
            assert self.process is not None and self.process.stdout is not None
            with self.process.stdout as output:  # closed at its end (rerun stopped)
                for line in output:
                    match = re.search(rf"web-viewer at (http://{re.escape(LOCALHOST)}:\d+)", line)
                    if match and not found:
                        found.append(match.group(1))
                        ready.set()
                    log.debug("rerun: %s", line.rstrip())
            ready.set()

        threading.Thread(target=read, daemon=True).start()
        if not ready.wait(self.startup) or not found:
            self.__exit__(None, None, None)
            raise RuntimeError(f"rerun --serve-web did not start within {self.startup:.0f} s")
        return found[0]

    def __exit__(self, *exc: object) -> None:
        if self.process is not None:
            stop_group(self.process)


class Chromium:
    """Headless Chromium with its DevTools endpoint on 127.0.0.1 (a free port), in a fresh
    profile that is removed afterwards."""

    def __init__(self, binary: str, size: tuple[int, int], startup: float = 30.0) -> None:
        self.binary = binary
        self.size = size
        self.startup = startup
        self.profile = Path(tempfile.mkdtemp(prefix="mcpilco-chromium-"))
        self.process: subprocess.Popen[bytes] | None = None
        self.port = 0

    def __enter__(self) -> Chromium:
        command = [
            self.binary, "--headless=new", f"--user-data-dir={self.profile}",
            "--remote-debugging-address=127.0.0.1", "--remote-debugging-port=0",
            f"--window-size={self.size[0]},{self.size[1]}", "--no-first-run",
            "--no-default-browser-check", "--enable-unsafe-swiftshader",  # WebGL2 in software
            "--disable-background-networking", "--disable-component-update",
        ]  # fmt: skip
        if hasattr(os, "geteuid") and os.geteuid() == 0:
            command.append("--no-sandbox")  # Chromium refuses to run as root with its sandbox
        command.append("about:blank")
        self.process = subprocess.Popen(
            command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True
        )
        port_file = self.profile / "DevToolsActivePort"
        deadline = time.monotonic() + self.startup
        while time.monotonic() < deadline and self.process.poll() is None:
            text = port_file.read_text() if port_file.exists() else ""
            if text.strip():
                self.port = int(text.split()[0])
                return self
            time.sleep(0.1)
        self.__exit__(None, None, None)
        raise RuntimeError(f"{self.binary} did not open its DevTools port within {self.startup} s")

    def page_websocket(self) -> str:
        """The DevTools websocket URL of the browser's page."""
        with urllib.request.urlopen(f"http://{LOCALHOST}:{self.port}/json/list", timeout=10) as r:
            targets = json.load(r)
        pages = [t["webSocketDebuggerUrl"] for t in targets if t.get("type") == "page"]
        if not pages:
            raise RuntimeError("Chromium has no page to drive")
        return str(pages[0])

    def __exit__(self, *exc: object) -> None:
        if self.process is not None:
            stop_group(self.process)
        shutil.rmtree(self.profile, ignore_errors=True)


class DevTools:
    """A synchronous Chrome DevTools protocol client for one page."""

    def __init__(self, websocket_url: str, timeout: float = 60.0) -> None:
        self.url = websocket_url
        self.timeout = timeout
        self.ids = itertools.count(1)
        self.connection: ClientConnection | None = None

    def __enter__(self) -> DevTools:
        connection = connect(self.url, max_size=None, open_timeout=self.timeout)
        self.connection = connection.__enter__()
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self.connection is not None:
            self.connection.__exit__(kind, error, tb)

    def call(self, method: str, **params: Any) -> dict[str, Any]:
        """Send one command and return its ``result`` (events in between are dropped).

        Raises:
            RuntimeError: the browser answered with an error.
        """
        assert self.connection is not None, "use DevTools as a context manager"
        number = next(self.ids)
        self.connection.send(json.dumps({"id": number, "method": method, "params": params}))
        while True:
            message = json.loads(self.connection.recv(timeout=self.timeout))
            if message.get("id") != number:
                continue
            if "error" in message:
                raise RuntimeError(f"DevTools {method}: {message['error']}")
            return dict(message.get("result", {}))

    def navigate(self, url: str, size: tuple[int, int]) -> None:
        """Open ``url`` in a viewport of ``size`` (width, height) CSS pixels, scale 1."""
        self.call("Page.enable")
        self.call(
            "Emulation.setDeviceMetricsOverride",
            width=size[0], height=size[1], deviceScaleFactor=1, mobile=False,
        )  # fmt: skip
        self.call("Page.navigate", url=url)

    def evaluate(self, expression: str) -> Any:
        """The value of a JavaScript expression in the page (JSON-serialisable)."""
        result = self.call("Runtime.evaluate", expression=expression, returnByValue=True)
        if "exceptionDetails" in result:
            raise RuntimeError(f"JavaScript error: {result['exceptionDetails'].get('text')}")
        return result.get("result", {}).get("value")

    def screenshot(self) -> bytes:
        """The page as PNG bytes."""
        return base64.b64decode(self.call("Page.captureScreenshot", format="png")["data"])
