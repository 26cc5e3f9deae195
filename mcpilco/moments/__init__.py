"""Closed-form moment matching of Gaussians (PILCO, Deisenroth & Rasmussen 2011): through
sines and cosines, SE-kernel GPs and RBF networks, and a sine saturation."""

from mcpilco.moments.gaussian import Gaussian, JointGaussian
from mcpilco.moments.rbf import rbf_moments
from mcpilco.moments.trig import sine_saturation, trig_moments

__all__ = ["Gaussian", "JointGaussian", "rbf_moments", "sine_saturation", "trig_moments"]
