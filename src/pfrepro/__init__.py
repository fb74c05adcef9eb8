"""pfrepro: filters, models and experiment tools for the particle-filtering reproduction book.

Subpackages and modules
-----------------------
models      state-space models (UNGM family, CWPA, bearings-only tracking, stochastic
            volatility) and the model contract (which model capabilities each filter uses)
filters     KF, EKF, UKF, bootstrap PF + resampling, grid (point-mass) filter
metrics     the papers' error measures with Monte Carlo standard errors
montecarlo  batched Monte Carlo runner with per-filter random streams and timings
published   the papers' published tables as data
claims      claims registry and the verdict rule behind the scorecard
rng         per-run random streams (RunStreams): run i independent of the batch
"""
from . import claims, filters, metrics, models, montecarlo, noise, published, rng

__version__ = "0.1.0"
__all__ = ["claims", "filters", "metrics", "models", "montecarlo", "noise", "published", "rng"]
