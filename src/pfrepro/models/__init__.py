"""State-space models: UNGM family, linear-Gaussian / CWPA, bearings-only tracking."""
from .base import Simulation, StateSpaceModel
from .bot import BearingsOnly, wrap_angle
from .linear import CWPA, LinearGaussianModel, van_loan_discretize
from .ungm import UNGM

__all__ = ["Simulation", "StateSpaceModel", "UNGM", "LinearGaussianModel", "CWPA",
           "van_loan_discretize", "BearingsOnly", "wrap_angle"]
from .parameterized import FixedParameterModel, ParameterizedModel  # noqa: E402,F401  (dual estimation: DPF chapter)
