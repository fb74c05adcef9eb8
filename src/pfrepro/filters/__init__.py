"""Filters: Kalman family, bootstrap particle filter with resampling schemes, grid filter."""
from .base import Filter, FilterDivergenceError, FilterDivergenceWarning, FilterResult, GaussianFilter
from .cmspf import CMSParticleFilter, OracleCMSParticleFilter
from .espf import EvolutionSamplingParticleFilter
from .gpff import GaussianParticleFlowFilter
from .grid import GridFilter
from .imm import IMMKalman, IMMParticleFilter, IMMPFOR  # noqa: F401  (interacting multiple model filters)
from .kalman import ExtendedKalmanFilter, KalmanFilter, kalman_update
from .particle import BootstrapParticleFilter, normalize_log_weights
from .resampling import (RESAMPLING_SCHEMES, effective_sample_size, multinomial_resample,
                         offspring_counts, resample, residual_resample, stratified_resample,
                         systematic_resample)
from .sigma_points import ScaledSigmaPoints, unscented_transform
from .ukf import UnscentedKalmanFilter

__all__ = ["Filter", "FilterResult", "GaussianFilter", "FilterDivergenceError", "FilterDivergenceWarning", "KalmanFilter",
           "ExtendedKalmanFilter", "kalman_update", "UnscentedKalmanFilter", "ScaledSigmaPoints",
           "unscented_transform", "BootstrapParticleFilter", "normalize_log_weights", "GridFilter", "GaussianParticleFlowFilter",
           "resample", "multinomial_resample", "stratified_resample", "systematic_resample",
           "residual_resample", "offspring_counts", "effective_sample_size", "RESAMPLING_SCHEMES",
           "CMSParticleFilter", "OracleCMSParticleFilter", "EvolutionSamplingParticleFilter",
           "AuxiliaryParticleFilter",
           "RegularizedParticleFilter",
           "GaussianProposalParticleFilter",
           "ParticleFlowParticleFilter",
           "JumpMarkovParticleFilter",
           "SMC2"]
from .dual_pf import DualParticleFilter; from .dual_ekf import DualExtendedKalmanFilter; from .liu_west import LiuWestFilter; from .theta_grid import ThetaGridReference  # noqa: E402,E702,F401
from .auxiliary import AuxiliaryParticleFilter  # noqa: E402
from .regularized import RegularizedParticleFilter  # noqa: E402
from .gaussian_proposal import GaussianProposalParticleFilter  # noqa: E402
from .pfpf import ParticleFlowParticleFilter  # noqa: E402
from .jump_markov_pf import JumpMarkovParticleFilter  # noqa: E402
from .smc2 import SMC2  # noqa: E402
