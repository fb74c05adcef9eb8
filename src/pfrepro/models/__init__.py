"""State-space models: UNGM family, linear-Gaussian / CWPA, bearings-only tracking, stochastic
volatility; the model contract (which model capabilities each filter needs) is in :mod:`.base`."""
from .base import (CAPABILITIES, ModelContractError, Simulation, StateSpaceModel, has_capability,
                   missing_capabilities, require_capabilities)
from .bot import BearingsOnly, wrap_angle
from .linear import CWPA, LinearGaussianModel, van_loan_discretize
from .sv import StochasticVolatility
from .ungm import UNGM
from .jump_markov import JumpMarkovSystem, validate_transition_matrix  # noqa: F401  (multiple-model systems; tracking models in .tracking)

__all__ = ["Simulation", "StateSpaceModel", "ModelContractError", "CAPABILITIES", "has_capability",
           "missing_capabilities", "require_capabilities", "UNGM", "LinearGaussianModel", "CWPA",
           "van_loan_discretize", "BearingsOnly", "wrap_angle", "StochasticVolatility"]
from .parameterized import FixedParameterModel, ParameterizedModel  # noqa: E402,F401  (dual estimation: DPF chapter)
