"""Exceptions with one-line messages that name what went wrong."""


class ConfigError(ValueError):
    """A configuration value is invalid; the message names the key and the value."""


class RefusedTargetError(ConfigError):
    """A configuration read from a file names a ``_target_`` that may not be instantiated
    (a builtin, a function, or a class outside mcpilco's extension points)."""


class NotPositiveDefiniteError(RuntimeError):
    """A kernel matrix stayed non-positive-definite after the largest jitter was tried."""


class NonFiniteError(RuntimeError):
    """A reading, action, state or model output is NaN or infinite; the message names the
    trial (where known), the time step and the component."""


class SimulationError(RuntimeError):
    """A simulator could not advance the state (an integrator failed or ran past its
    bound on work, MuJoCo reported an unstable acceleration)."""


class RunInUseError(RuntimeError):
    """Another live process holds the run directory's lock."""


class ForeignRunError(ConfigError):
    """A directory holds another kind of run or another experiment: it is refused and
    left untouched (no failure mark, no log)."""


class RunFileError(ValueError):
    """A file of a run directory (``summary.csv``, ``run.json``) is corrupt or
    inconsistent; the message names it."""


class Terminated(KeyboardInterrupt):
    """The process received SIGTERM (a scheduler's preemption or time limit): handled
    like Ctrl-C, finished units are kept."""


class CheckpointError(ValueError):
    """A checkpoint file is missing, corrupt, or holds more than tensors."""
