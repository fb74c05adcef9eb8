"""Filters: the Kalman family, particle filters and their resampling schemes, grid filters,
the papers' filters (GPFF, CMS-PF, ESPF, dual PF, IMM-PF) and today's methods.

Every filter is importable from here (``from pfrepro.filters import KalmanFilter``), whichever
module defines it.
"""
from .auxiliary import AuxiliaryParticleFilter
from .base import Filter, FilterDivergenceError, FilterDivergenceWarning, FilterResult, GaussianFilter
from .cmspf import CMSParticleFilter, CMSStep, OracleCMSParticleFilter
from .dual_ekf import DualExtendedKalmanFilter
from .dual_pf import DualParticleFilter
from .ekf_variants import PreviousEstimateJacobianEKF
from .espf import EvolutionSamplingParticleFilter
from .gaussian_proposal import GaussianProposalParticleFilter
from .gpff import GaussianParticleFlowFilter
from .grid import GridFilter, GridMassWarning
from .imm import IMMPFOR, IMMKalman, IMMParticleFilter
from .jump_markov_pf import JumpMarkovParticleFilter
from .kalman import ExtendedKalmanFilter, KalmanFilter, kalman_update
from .liu_west import LiuWestFilter
from .parameter_learning import ParameterLearningFilter
from .particle import BootstrapParticleFilter, WeightCollapseWarning, normalize_log_weights
from .pfpf import ParticleFlowParticleFilter
from .regularized import RegularizedParticleFilter
from .resampling import (RESAMPLING_SCHEMES, effective_sample_size, multinomial_resample,
                         offspring_counts, resample, residual_resample, stratified_resample,
                         systematic_resample)
from .sigma_points import ScaledSigmaPoints, unscented_transform
from .smc2 import SMC2
from .smc_steps import ParticleLoop
from .theta_grid import ThetaGridReference
from .ukf import UnscentedKalmanFilter

__all__ = [
    # the filter interface and its result
    "Filter", "FilterResult", "GaussianFilter", "FilterDivergenceError", "FilterDivergenceWarning",
    "WeightCollapseWarning",
    # Kalman family
    "KalmanFilter", "ExtendedKalmanFilter", "kalman_update", "PreviousEstimateJacobianEKF",
    "UnscentedKalmanFilter", "ScaledSigmaPoints", "unscented_transform",
    # particle filters and resampling
    "BootstrapParticleFilter", "normalize_log_weights", "resample", "multinomial_resample",
    "stratified_resample", "systematic_resample", "residual_resample", "offspring_counts",
    "effective_sample_size", "RESAMPLING_SCHEMES",
    # grid (point-mass) filter
    "GridFilter", "GridMassWarning",
    # the papers' filters
    "GaussianParticleFlowFilter", "CMSParticleFilter", "OracleCMSParticleFilter", "CMSStep",
    "EvolutionSamplingParticleFilter",
    # state and static parameter (dual PF chapter; the family's base class first)
    "ParameterLearningFilter", "DualParticleFilter", "DualExtendedKalmanFilter", "LiuWestFilter", "ThetaGridReference",
    # interacting multiple models (IMM-PF chapter)
    "IMMKalman", "IMMParticleFilter", "IMMPFOR",
    # today's methods (the loop they share first)
    "ParticleLoop", "AuxiliaryParticleFilter", "RegularizedParticleFilter", "GaussianProposalParticleFilter",
    "ParticleFlowParticleFilter", "JumpMarkovParticleFilter", "SMC2",
]
