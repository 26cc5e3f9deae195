"""Covariance functions, batched over independent GP outputs (one file per kernel)."""

from mcpilco.kernels.base import Kernel, KernelFactory, KernelShape
from mcpilco.kernels.constant import Constant
from mcpilco.kernels.gip import GeometricPolynomial
from mcpilco.kernels.linear import Linear
from mcpilco.kernels.physical import PhysicalBasis
from mcpilco.kernels.polynomial import MultiplicativePolynomial
from mcpilco.kernels.se import SquaredExponential
from mcpilco.kernels.sum import Sum

__all__ = [
    "Constant",
    "GeometricPolynomial",
    "Kernel",
    "KernelFactory",
    "KernelShape",
    "Linear",
    "MultiplicativePolynomial",
    "PhysicalBasis",
    "SquaredExponential",
    "Sum",
]
