"""Latent-variable GP models of high-dimensional dynamics (thesis Part III, chapter 6)."""

from mcpilco.latent.cgpdm import CGPDM, TrainingData
from mcpilco.latent.pca import principal_components

__all__ = ["CGPDM", "TrainingData", "principal_components"]
