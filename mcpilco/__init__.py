"""mcpilco: Gaussian-process model-based reinforcement learning for mechanical systems."""

__version__ = "0.1.0"
