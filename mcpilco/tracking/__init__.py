"""Run logging: MCAP files of every rollout, the reader, and the Rerun streamer.

The streamer (and with it rerun-sdk, a large import) loads only when first asked for:
a run with ``tracking.rerun=off`` never imports it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from mcpilco.tracking.base import TrialObserver
from mcpilco.tracking.mcap_log import McapLogger
from mcpilco.tracking.reader import RunLog, read_run_log

if TYPE_CHECKING:
    from mcpilco.tracking.rerun_stream import RerunStreamer

__all__ = ["McapLogger", "RerunStreamer", "RunLog", "TrialObserver", "read_run_log"]


def __getattr__(name: str) -> Any:
    if name == "RerunStreamer":
        from mcpilco.tracking.rerun_stream import RerunStreamer

        return RerunStreamer
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
