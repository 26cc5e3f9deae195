"""Command-line entry points (thin: build from config, run, report)."""
