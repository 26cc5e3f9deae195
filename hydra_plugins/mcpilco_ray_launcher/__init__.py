"""mcpilco's Hydra launcher for Ray clusters (``hydra/launcher=ray``); see ``ray_launcher``."""
