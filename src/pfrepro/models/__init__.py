"""State-space models: UNGM family, linear-Gaussian / CWPA, bearings-only tracking, stochastic
volatility, models with a static parameter (dual estimation), the re-entry problem, and
jump-Markov (multiple-model) systems with their tracking models; the model contract (which model
capabilities each filter needs) is in :mod:`.base`.

``__all__`` lists every public class of the model modules (a test checks it), and the API
reference's summary table is generated from it.
"""
from .base import (CAPABILITIES, ModelContractError, Simulation, StateSpaceModel, has_capability,
                   missing_capabilities, require_capabilities)
from .bot import BearingsOnly, wrap_angle
from .continuous import ContinuousParameterizedModel
from .jump_markov import JumpMarkovSimulation, JumpMarkovSystem, validate_transition_matrix
from .linear import CWPA, LinearGaussianModel, van_loan_discretize
from .linear_theta import LinearTheta
from .parameterized import FixedParameterModel, ParameterizedModel
from .reentry import Reentry
from .sv import StochasticVolatility
from .tracking import RadarTrackingModel
from .ungm import UNGM
from .ungm_theta import UNGMTheta

__all__ = ["Simulation", "StateSpaceModel", "ModelContractError", "CAPABILITIES", "has_capability",
           "missing_capabilities", "require_capabilities", "UNGM", "LinearGaussianModel", "CWPA",
           "van_loan_discretize", "BearingsOnly", "wrap_angle", "StochasticVolatility",
           # a static parameter θ (dual PF chapter)
           "ParameterizedModel", "FixedParameterModel", "ContinuousParameterizedModel", "UNGMTheta",
           "LinearTheta", "Reentry",
           # multiple models (IMM-PF chapter)
           "JumpMarkovSystem", "JumpMarkovSimulation", "validate_transition_matrix", "RadarTrackingModel"]
