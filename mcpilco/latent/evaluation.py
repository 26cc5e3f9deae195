"""Prediction error of a cloth model (thesis eq. 6.13) and the baselines it is judged by."""

from __future__ import annotations

import numpy as np


def point_distance_per_step(true: np.ndarray, predicted: np.ndarray) -> np.ndarray:
    """The mean over the P mesh points of the Euclidean distance between true and predicted
    points, per time step.

    Args:
        true, predicted: ``[S, N, 3P]`` (x₁ y₁ z₁ x₂ … per row, m).
    Returns:
        ``[S, N]`` (m).
    """
    if true.shape != predicted.shape or true.shape[-1] % 3:
        raise ValueError(f"shapes {true.shape} and {predicted.shape} must agree, [S, N, 3P]")
    difference = (true - predicted).reshape(*true.shape[:-1], -1, 3)
    return np.linalg.norm(difference, axis=-1).mean(axis=-1)


def point_distance(true: np.ndarray, predicted: np.ndarray) -> np.ndarray:
    """Eq. 6.13: :func:`point_distance_per_step` averaged over time, ``[S]`` (m)."""
    return point_distance_per_step(true, predicted).mean(axis=-1)


def still_baseline(true: np.ndarray) -> np.ndarray:
    """Every sequence predicted as its first frame (the cloth stays still) ``[S, N, 3P]``."""
    return np.broadcast_to(true[:, :1], true.shape).copy()


def rigid_baseline(true: np.ndarray, controls: np.ndarray) -> np.ndarray:
    """The first frame translated with the mean end-effector displacement (the cloth moves
    as a rigid body with its grip) ``[S, N, 3P]``; ``controls [S, N−1, 3k]`` hold the
    displacements of k end-effectors."""
    steps = controls.reshape(*controls.shape[:-1], -1, 3).mean(axis=-2)  # [S, N−1, 3]
    offset = np.concatenate([np.zeros_like(steps[:, :1]), np.cumsum(steps, axis=1)], axis=1)
    first = true[:, :1].reshape(true.shape[0], 1, -1, 3)
    return (first + offset[:, :, None, :]).reshape(true.shape)
