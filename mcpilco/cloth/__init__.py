"""A simulated cloth moved by two end-effectors, and its data sets (thesis §6.4)."""

from mcpilco.cloth.dataset import ClothDataset, Excitation, generate, read_csv_sequences
from mcpilco.cloth.simulation import ClothParameters, ClothSimulation

__all__ = [
    "ClothDataset",
    "ClothParameters",
    "ClothSimulation",
    "Excitation",
    "generate",
    "read_csv_sequences",
]
