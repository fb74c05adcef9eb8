"""The small interface every filter shares, and what it returns.

:class:`~pfrepro.results.FilterResult` is defined in :mod:`pfrepro.results` (the Monte Carlo runner and the
filters both import it from there) and re-exported here, so ``from pfrepro.filters.base import
FilterResult`` keeps working.
"""
from __future__ import annotations

import warnings

import numpy as np

from ..models.base import ModelContractError, require_capabilities
from ..results import FilterResult
from ..rng import check_rng
from ..validation import MEASUREMENT_SHAPES, as_covariance, as_measurements, as_vector

__all__ = ["FilterResult", "Filter", "GaussianFilter", "FilterDivergenceError", "FilterDivergenceWarning",
           "DIVERGENCE_POLICIES", "ModelContractError", "check_divergence_policy", "mark_diverged",
           "gaussian_loglik", "MEASUREMENT_SHAPES"]


class FilterDivergenceError(FloatingPointError):
    """Raised when a filter's state becomes non-finite (e.g. a covariance loses definiteness)."""


class FilterDivergenceWarning(RuntimeWarning):
    """Some runs diverged and were stopped (NaN from the step in ``diagnostics["diverged_at"]``);
    the other runs are unaffected."""


#: what a filter with an ``on_divergence`` setting does with a diverging run
DIVERGENCE_POLICIES = ("warn", "drop", "raise")


class Filter:
    """Base class: a filter is built from a model plus settings, then run on measurements.

    ``filter(y, rng)`` takes measurements ``y`` and returns a :class:`FilterResult`;
    all runs are processed in one call. Accepted shapes of ``y`` (see
    :func:`pfrepro.validation.as_measurements`): ``(runs, T, dim_y)`` always;
    ``(T,)`` for one run of scalar measurements (``dim_y == 1``); ``(T, dim_y)``
    for one run only when ``dim_y > 1`` (a 2-D ``y`` with ``dim_y == 1`` is
    ambiguous and refused). Stochastic filters need ``rng``, a
    ``numpy.random.Generator`` or ``pfrepro.rng.RunStreams``; deterministic
    filters ignore it.

    ``model_requirements`` lists the model capabilities (keys of
    :data:`pfrepro.models.CAPABILITIES`) the filter uses; the constructor raises
    :class:`~pfrepro.models.ModelContractError` when the model lacks one.
    """

    name = "filter"
    needs_rng = False
    #: model capabilities this filter calls (the model contract, ``pfrepro.models.base``)
    model_requirements: tuple = ("transition_sampler", "likelihood")

    def __init__(self, model, m0=None, P0=None):
        require_capabilities(model, self.model_requirements, type(self).__name__)
        self.model = model
        # the filter's initial distribution N(m0, P0); defaults to the model's
        self.m0 = model.m0 if m0 is None else as_vector(m0, "m0", model.dim_x)
        self.P0 = model.P0 if P0 is None else as_covariance(P0, "P0", model.dim_x)

    def sample_prior(self, rng: np.random.Generator, shape) -> np.ndarray:
        """Draws from the filter's initial distribution N(m0, P0), shape ``(*shape, dim_x)``."""
        z = rng.standard_normal(tuple(shape) + (self.model.dim_x,))
        return self.m0 + z @ np.linalg.cholesky(self.P0).T

    def _prepare(self, y, rng):
        y = as_measurements(y, self.model.dim_y)
        if self.needs_rng:
            check_rng(rng, f"{type(self).__name__}.filter's rng")
        return y

    def filter(self, y, rng: np.random.Generator | None = None) -> FilterResult:
        """Filter measurements ``y`` of every run at once.

        Parameters
        ----------
        y : array_like
            Measurements (runs, T, dim_y), ``y[:, k - 1]`` = y_k; one run may be given
            as (T, dim_y).
        rng : numpy.random.Generator or RunStreams, optional
            Randomness of a stochastic filter (required for particle filters; see
            :mod:`pfrepro.rng` for per-run streams); ignored by deterministic ones.

        Returns
        -------
        FilterResult
            Estimates of x_1..x_T, ``x`` of shape (runs, T, dim_x).
        """
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name})"


class GaussianFilter(Filter):
    """Shared recursion of the Kalman-family filters (KF, EKF, UKF).

    Subclasses provide ``predict(x, P, k)`` and ``update(x, P, y)`` on batched
    ``x`` (runs, n) and ``P`` (runs, n, n); this class runs them over time and
    checks the result. ``m0``/``P0`` override the model's initial distribution.

    An ``update`` stores its innovation ``nu`` (runs, m) and innovation covariance
    ``S`` (runs, m, m) in ``self._last_innovation``; the recursion turns them into
    the Gaussian approximation of the one-step predictive log-likelihood

        log p(y_k | y_1:k-1) ≈ log N(nu_k; 0, S_k)

    (exact for the KF on a linear-Gaussian model), returned in
    ``diagnostics["log_likelihood"]`` (runs, T) and summed over k in
    ``diagnostics["log_evidence"]`` (runs,). An IMM uses them as mode likelihoods.

    Divergence (``on_divergence``, as the GPFF and the dual EKF): a run whose estimate
    becomes non-finite is judged on its own. "warn" (default): its estimates, covariances
    and log-likelihoods are NaN from that step on, ``diagnostics["diverged"]`` (runs,) flags
    it, ``diagnostics["diverged_at"]`` (runs,) holds the step (0 = never) and
    ``diagnostics["n_diverged"]`` the count, and one ``FilterDivergenceWarning`` names the
    filter and the runs; the other runs are computed exactly as without it. "drop": the
    same, silent. "raise": ``FilterDivergenceError``.
    """

    _last_innovation = None
    #: what to do with a diverging run (see the class docstring); a constructor argument
    on_divergence = "warn"

    def __init__(self, model, m0=None, P0=None, on_divergence: str = "warn"):
        super().__init__(model, m0, P0)
        self.on_divergence = check_divergence_policy(on_divergence)

    def predict(self, x, P, k):
        """Time update from step k - 1 to k: ``(x, P)`` of shapes (runs, n), (runs, n, n) -> predicted ``(x, P)``."""
        raise NotImplementedError

    def update(self, x, P, y):
        """Measurement update with y_k (runs, m): predicted ``(x, P)`` -> posterior ``(x, P)``."""
        raise NotImplementedError

    def filter(self, y, rng=None) -> FilterResult:
        y = self._prepare(y, rng)
        runs, T, _ = y.shape
        n = self.model.dim_x
        x = np.broadcast_to(self.m0, (runs, n)).copy()
        P = np.broadcast_to(self.P0, (runs, n, n)).copy()
        xs = np.empty((runs, T, n))
        Ps = np.empty((runs, T, n, n))
        loglik = np.empty((runs, T))
        with np.errstate(all="ignore"):
            for k in range(1, T + 1):
                x, P = self.predict(x, P, k)
                x, P = self.update(x, P, y[:, k - 1])
                xs[:, k - 1], Ps[:, k - 1] = x, P
                loglik[:, k - 1] = gaussian_loglik(*self._last_innovation)
        diag = mark_diverged(self.name, self.on_divergence, np.isfinite(xs).all(axis=-1), (xs, Ps, loglik))
        return FilterResult(xs, Ps, diagnostics={"log_likelihood": loglik, "log_evidence": loglik.sum(axis=1),
                                                 **diag})


def check_divergence_policy(on_divergence) -> str:
    """``on_divergence`` must be one of :data:`DIVERGENCE_POLICIES`."""
    if not isinstance(on_divergence, str) or on_divergence not in DIVERGENCE_POLICIES:
        raise ValueError(f"on_divergence must be one of {DIVERGENCE_POLICIES}, got {on_divergence!r}")
    return on_divergence


def mark_diverged(name: str, policy: str, finite, arrays, stacklevel: int = 3) -> dict:
    """Judge divergence run by run and mark the diverged runs (the Kalman-family rule).

    ``finite`` (runs, T) says where a run's estimate is finite; a run is diverged from its
    first non-finite step on, and every array of ``arrays`` (runs axis first, time axis
    second) is set to NaN there, in place, so no huge finite number before the NaN passes
    on as an estimate of a lost run. ``policy`` "raise" raises
    :class:`FilterDivergenceError`, "warn" gives one :class:`FilterDivergenceWarning`
    naming ``name`` and the runs, "drop" is silent. Returns the diagnostics ``diverged``
    (runs,) bool, ``diverged_at`` (runs,) (step, 0 = never) and ``n_diverged``.
    """
    finite = np.asarray(finite, dtype=bool)
    runs = finite.shape[0]
    bad = ~finite.all(axis=1)
    diverged_at = np.where(bad, np.argmin(finite, axis=1) + 1, 0)
    n_bad = int(bad.sum())
    if n_bad:
        idx = np.flatnonzero(bad)
        msg = (f"{name}: {n_bad} of {runs} runs diverged (non-finite estimates, first at step "
               f"{int(diverged_at[bad].min())}) in runs {idx[:10].tolist()}{' ...' if n_bad > 10 else ''}")
        if policy == "raise":
            raise FilterDivergenceError(msg)
        for r in idx:
            for a in arrays:
                a[r, diverged_at[r] - 1:] = np.nan
        if policy == "warn":
            warnings.warn(FilterDivergenceWarning(
                msg + "; their estimates are NaN from diagnostics['diverged_at'] on, the other runs are kept "
                "(on_divergence='drop' silences this, 'raise' makes it an error)"), stacklevel=stacklevel)
    return {"diverged": bad, "diverged_at": diverged_at, "n_diverged": n_bad}


def gaussian_loglik(nu, S):
    """log N(nu; 0, S) for batched innovations ``nu`` (runs, m) and covariances ``S`` (runs, m, m).

    A covariance without a Cholesky factor (a diverged run) gives NaN in its own run only;
    the batch is factorised at once first, so the other runs' numbers do not change."""
    L = _cholesky_per_run(S)
    z = np.linalg.solve(L, nu[..., None])[..., 0]
    m = nu.shape[-1]
    return -0.5 * np.sum(z * z, axis=-1) - np.log(np.diagonal(L, axis1=-2, axis2=-1)).sum(axis=-1) \
        - 0.5 * m * np.log(2.0 * np.pi)


def _cholesky_per_run(S):
    """``np.linalg.cholesky`` over a batch, NaN (not a ``LinAlgError`` for the whole batch) for
    a matrix that is not positive definite; bit-identical to the batched call otherwise."""
    try:
        return np.linalg.cholesky(S)
    except np.linalg.LinAlgError:
        pass
    out = np.empty(S.shape)
    for idx in np.ndindex(*S.shape[:-2]):
        try:
            out[idx] = np.linalg.cholesky(S[idx])
        except np.linalg.LinAlgError:
            out[idx] = np.nan
    return out
