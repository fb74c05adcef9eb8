"""Error metrics of the papers, with Monte Carlo uncertainty.

Conventions: ``x_true`` and ``x_est`` are ``(runs, T, dim_x)`` and aligned
(``x_true`` *without* the initial state: pass ``sim.x[:, 1:]``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["mse", "mse_per_component_over_time", "mse_per_component", "rmse", "rmse_over_time",
           "McSummary", "mc_summary"]


def _check(x_true, x_est):
    x_true = np.asarray(x_true, float)
    x_est = np.asarray(x_est, float)
    if x_true.shape != x_est.shape or x_true.ndim != 3:
        raise ValueError(f"x_true and x_est must both be (runs, T, dim_x); got {x_true.shape} and {x_est.shape}")
    return x_est - x_true


def mse(x_true, x_est) -> np.ndarray:
    """Dimension-free MSE per run, Zhang et al. 2016 eq (56): (1/(T d)) sum_k ||x_k - x_hat_k||^2."""
    e = _check(x_true, x_est)
    return np.mean(e * e, axis=(1, 2))


def mse_per_component_over_time(x_true, x_est) -> np.ndarray:
    """Per-component MSE at each time over the runs, Zhang et al. 2016 eq (61): ``(T, dim_x)``."""
    e = _check(x_true, x_est)
    return np.mean(e * e, axis=0)


def mse_per_component(x_true, x_est) -> np.ndarray:
    """Time-averaged squared error per run and component, ``(runs, dim_x)`` (Table 2 of Zhang et al.)."""
    e = _check(x_true, x_est)
    return np.mean(e * e, axis=1)


def rmse(x_true, x_est) -> np.ndarray:
    """Per-run RMSE over time, sqrt((1/T) sum_k ||x_k - x_hat_k||^2), ``(runs,)``."""
    e = _check(x_true, x_est)
    return np.sqrt(np.mean(np.sum(e * e, axis=2), axis=1))


def rmse_over_time(x_true, x_est) -> np.ndarray:
    """RMSE at each time step across runs, sqrt(mean_runs ||e_k||^2), ``(T,)``."""
    e = _check(x_true, x_est)
    return np.sqrt(np.mean(np.sum(e * e, axis=2), axis=0))


@dataclass(frozen=True)
class McSummary:
    """Mean, sample standard deviation and standard error of the mean over runs."""

    mean: float
    std: float
    se: float
    n: int

    def interval(self, z: float = 1.96) -> tuple[float, float]:
        """Normal-approximation interval mean ± z·SE (z = 1.96: 95 %)."""
        return self.mean - z * self.se, self.mean + z * self.se


def mc_summary(values, nan_policy: str = "raise") -> McSummary:
    """Summarise per-run values; the standard error is std / sqrt(n).

    ``nan_policy``: ``"raise"`` (default) refuses NaN values with a ``ValueError``
    naming how many there are (a diverged run must not disappear into a NaN mean);
    ``"omit"`` summarises the finite values only (``n`` counts them). Infinite
    values are refused either way.
    """
    if nan_policy not in ("raise", "omit"):
        raise ValueError(f"nan_policy must be 'raise' or 'omit', got {nan_policy!r}")
    v = np.asarray(values, float).ravel()
    nan = np.isnan(v)
    if nan.any():
        if nan_policy == "raise":
            raise ValueError(f"values contain {int(nan.sum())} NaN of {v.size} (e.g. diverged runs); "
                             "drop them explicitly or pass nan_policy='omit'")
        v = v[~nan]
    if np.isinf(v).any():
        raise ValueError(f"values contain {int(np.isinf(v).sum())} infinite entries")
    if v.size == 0:
        raise ValueError("no values to summarise")
    std = float(v.std(ddof=1)) if v.size > 1 else float("nan")
    return McSummary(float(v.mean()), std, std / np.sqrt(v.size), int(v.size))
