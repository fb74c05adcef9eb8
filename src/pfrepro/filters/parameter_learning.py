"""The parameter-learning family: filters that estimate a static parameter θ beside the state.

The dual PF (:mod:`~pfrepro.filters.dual_pf`), the dual EKF (:mod:`~pfrepro.filters.dual_ekf`),
Liu–West (:mod:`~pfrepro.filters.liu_west`), SMC² (:mod:`~pfrepro.filters.smc2`) and the exact
θ-grid reference (:mod:`~pfrepro.filters.theta_grid`) run on a
:class:`~pfrepro.models.parameterized.ParameterizedModel` (transition and measurement take θ,
the prior of θ is uniform on ``model.bounds``) instead of a plain state-space model. What they
share is set up here, and each of them imports it from this module, not from a sibling:

* the model contract (:func:`check_parameterized`): the model is a ParameterizedModel that
  overrides the methods the filter calls, and θ is scalar where the filter needs it to be;
  refused with a :class:`~pfrepro.models.ModelContractError` naming the filter and what is
  missing, when the filter is built;
* the prior N(m0, P0) of the state, the model's unless given (checked as ``Filter`` does);
* the base class :class:`ParameterLearningFilter`, whose constructor does both.

Every filter of the family reports the θ estimate per step in ``diagnostics["theta"]`` and
its posterior variance in ``diagnostics["theta_var"]``.
"""
from __future__ import annotations

from ..models.base import ModelContractError
from ..models.parameterized import ParameterizedModel
from ..validation import as_covariance, as_vector
from .base import Filter

__all__ = ["ParameterLearningFilter", "check_parameterized", "init_parameterized_filter"]


def check_parameterized(model, who: str, scalar_theta: bool = True, needs=("f", "h")):
    """The dual-estimation filters' model contract: a ParameterizedModel implementing ``needs``.

    Raises :class:`~pfrepro.models.ModelContractError` (a ``TypeError``) naming the filter and
    what the model lacks.
    """
    if not isinstance(model, ParameterizedModel):
        raise ModelContractError(f"{who} needs a pfrepro.models.ParameterizedModel (a model with an unknown "
                                 f"parameter θ), got {type(model).__name__}")
    lacks = [m for m in needs if getattr(type(model), m, None) is getattr(ParameterizedModel, m)]
    if lacks:
        raise ModelContractError(f"{who} needs a model implementing {', '.join(needs)}; "
                                 f"{type(model).__name__} does not implement {', '.join(lacks)}")
    if scalar_theta and model.dim_theta != 1:
        raise ValueError(f"{who} estimates a scalar parameter; model has dim_theta = {model.dim_theta}")
    return model


def init_parameterized_filter(filt, model, who: str, m0=None, P0=None, scalar_theta=True, needs=("f", "h")):
    """What ``Filter.__init__`` does for a StateSpaceModel, for a ParameterizedModel: the contract
    check, the model and the prior N(m0, P0) (default: the model's)."""
    check_parameterized(model, who, scalar_theta, needs)
    filt.model = model
    filt.m0 = model.m0 if m0 is None else as_vector(m0, "m0", model.dim_x)
    filt.P0 = model.P0 if P0 is None else as_covariance(P0, "P0", model.dim_x)


class ParameterLearningFilter(Filter):
    """Base class of the filters that estimate a static parameter θ with the state (module docstring).

    Parameters
    ----------
    model : ParameterizedModel
        A :class:`~pfrepro.models.parameterized.ParameterizedModel`.
    m0, P0 : ndarray, optional
        The state prior N(m0, P0) (default: the model's).
    needs : tuple of str, optional
        Model methods the filter calls (default :attr:`parameter_needs`).
    """

    #: model methods (overrides of ParameterizedModel) a filter of the family calls by default
    parameter_needs: tuple = ("f", "h")
    #: True for a filter that estimates a scalar θ only
    scalar_theta: bool = True

    def __init__(self, model, m0=None, P0=None, needs=None):
        init_parameterized_filter(self, model, type(self).__name__, m0, P0, self.scalar_theta,
                                  self.parameter_needs if needs is None else tuple(needs))
