"""Tracking: observers of the trial loop (MCAP log of every rollout) and its reader."""

from mcpilco.tracking.base import TrialObserver
from mcpilco.tracking.mcap_log import McapLogger
from mcpilco.tracking.reader import RunLog, read_run_log
from mcpilco.tracking.rerun_stream import RerunStreamer

__all__ = ["McapLogger", "RerunStreamer", "RunLog", "TrialObserver", "read_run_log"]
