"""Exceptions with one-line messages that name what went wrong."""


class ConfigError(ValueError):
    """A configuration value is invalid; the message names the key and the value."""


class NotPositiveDefiniteError(RuntimeError):
    """A kernel matrix stayed non-positive-definite after the largest jitter was tried."""
