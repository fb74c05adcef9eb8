"""State-space models: UNGM family, linear-Gaussian / CWPA, bearings-only tracking."""
from .base import Simulation, StateSpaceModel
from .bot import BearingsOnly, wrap_angle
from .linear import CWPA, LinearGaussianModel, van_loan_discretize
from .ungm import UNGM
from .jump_markov import JumpMarkovSystem, validate_transition_matrix  # noqa: F401  (multiple-model systems; tracking models in .tracking)

__all__ = ["Simulation", "StateSpaceModel", "UNGM", "LinearGaussianModel", "CWPA",
           "van_loan_discretize", "BearingsOnly", "wrap_angle"]
