"""Chaos-map-sampling particle filter, Ning, Chen, Zhao, He & Shi (2011), batched over runs.

Ning et al. 2011, sec 2.2 (Steps 1-5), with the prior as proposal::

    1. x_0^i ~ p(x_0), w_0^i = 1/N.
    2. For k >= 1:
       2.1 predict  x1^i = f(x_{k-1}^i, k) + w^i                      (N predicted particles)
       2.2 map      x2^j = c_j + r_j eta (big_j - small_j)           (N map particles)
           c_j: a centre -- the paper prints the *true state* x_k here; sec 2.3 note 1
           replaces it by high-weight particles big(x) and adds the estimate x_hat_k.
       2.3 pool     x' = x1 U x2                                      (2N candidates)
       2.4 select   keep the N candidates with the highest p(z_k | x) (the "upper half")
       2.5 weight   w_k^i ∝ w_{k-1}^i p(z_k | x_k^i)                  (eq 3, prior proposal)
    3. resample when N_eff = round(1 / sum w^2) < N_th.
    4. output    x_hat_k = sum w_k^i x_k^i                           (eq 4)

Reading taken here (the paper leaves these open; see the chapter):

* "big" particles are the ``n_big`` predicted particles with the largest weight
  w_{k-1} p(z_k | x1); "small" the ``n_big`` with the smallest; they are paired in
  rank order (largest with smallest, second with second-smallest, ...).
* Centres: the weighted mean x_hat_k of the predicted particles (note 1) and the
  ``n_big`` big particles; map particle j uses centre ``j mod (n_big + 1)``
  (x_hat_k is paired with the best/worst pair's spread).
* The previous weight w_{k-1} of a map particle is that of the big particle at
  its centre (of the best particle for the x_hat_k centre).
* ``eta`` is the adjustment factor (eta in Step 2.2, alpha in sec 2.3 / Fig. 6).

Map particles are not drawn from the proposal, and the selection keeps the N
largest likelihoods, so the weights of eq (3) are not proper importance weights:
the estimator is not consistent for E[x_k | z_1:k] (see the chapter).

:class:`OracleCMSParticleFilter` is the literal Step 2.2, centred on the *true*
state; it is not a filter (it needs ``x_true``) and exists only to show what the
published numbers would need.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..chaos import ChaosCarrier
from ..rng import take_runs
from ..validation import as_finite_float, check_positive_int, check_probability
from .base import Filter, FilterDivergenceError, FilterResult
from .particle import normalize_log_weights, warn_collapse
from .resampling import check_scheme, resampling_counts_function

__all__ = ["CMSParticleFilter", "OracleCMSParticleFilter", "CMSStep", "map_particles",
           "select_top_likelihood"]


def select_top_likelihood(loglik, n_keep: int, sort: bool = True) -> np.ndarray:
    """Indices ``(runs, n_keep)`` of the ``n_keep`` largest log-likelihoods per row (Step 2.4).

    ``loglik`` is ``(runs, M)`` with ``M >= n_keep``; NaN counts as -inf. With
    ``sort`` the indices are ordered by decreasing likelihood (otherwise in
    ``argpartition`` order, which is all a filter needs).
    """
    ll = np.asarray(loglik, dtype=float)
    if ll.ndim != 2:
        raise ValueError(f"loglik must be (runs, M), got shape {ll.shape}")
    n_keep = check_positive_int(n_keep, "n_keep")
    if n_keep > ll.shape[1]:
        raise ValueError(f"cannot keep {n_keep} of {ll.shape[1]} candidates")
    # NaN counts as -inf; without NaN the key is ``ll`` itself (no copy: the same numbers)
    key = np.where(np.isnan(ll), -np.inf, ll) if np.isnan(ll).any() else ll
    if n_keep < ll.shape[1]:
        part = np.argpartition(-key, n_keep - 1, axis=1)[:, :n_keep]
    else:
        part = np.broadcast_to(np.arange(ll.shape[1]), ll.shape).copy()
    if not sort:
        return part
    order = np.argsort(-np.take_along_axis(key, part, axis=1), axis=1, kind="stable")
    return np.take_along_axis(part, order, axis=1)


def _select_negated(neg, n_keep: int) -> np.ndarray:
    """``select_top_likelihood(-neg, n_keep, sort=False)`` for log-likelihoods held negated in
    ``neg`` (the key that function partitions; negation is exact): ``np.argpartition`` of ``neg``
    itself, with the NaN rule (NaN counts as -inf) applied only when a NaN is there (the sum of a
    row holding NaN is NaN). The filters write their pools' log-likelihoods negated straight into
    one buffer, so the pool is neither concatenated nor negated again."""
    if n_keep >= neg.shape[1] or (np.isnan(neg.sum()) and np.isnan(neg).any()):
        return select_top_likelihood(np.negative(neg), n_keep, sort=False)
    return np.argpartition(neg, n_keep - 1, axis=1)[:, :n_keep]


def map_particles(x_pred, lw_pred, logw_prev, r, eta: float, n_big: int, centre=None):
    """Map particles of Step 2.2, ``x2 = c + r eta (big - small)``, for a batch.

    Parameters
    ----------
    x_pred : ndarray
        ``(runs, N, d)`` predicted particles x1.
    lw_pred : ndarray
        ``(runs, N)`` their log-weights w_{k-1} p(z_k | x1) (unnormalised is fine).
    logw_prev : ndarray
        ``(runs, N)`` log w_{k-1} of the predicted particles.
    r : ndarray
        ``(runs, M, d)`` carrier values (one per map particle and component).
    eta : float
        Adjustment factor (> 0).
    n_big : int
        Number of big/small particles (1 <= n_big <= N // 2 unless N == 1).
    centre : ndarray or None
        None (sec 2.3 note 1: x_hat_k and the big particles) or a
        ``(runs, d)`` array -- the oracle reading of Step 2.2 (the true x_k).

    Returns
    -------
    x2 : ndarray
        ``(runs, M, d)`` mapped particles.
    logw_prev_map : ndarray
        ``(runs, M)`` log w_{k-1} carried to the mapped particles.
    centre_index : ndarray
        ``(M,)`` index of the big particle each mapped particle is centred on.
    """
    runs, N, d = x_pred.shape
    M = r.shape[1]
    off = (np.arange(runs) * N)[:, None]
    big, small = _big_small(lw_pred, n_big, off)
    flat_x = x_pred.reshape(runs * N, d)
    bi = big + off
    xb = np.take(flat_x, bi, axis=0)                                  # (runs, B, d)
    xs = np.take(flat_x, small + off, axis=0)
    spread = xb - xs                                                  # (runs, B, d)
    lwb = np.take(logw_prev.reshape(-1), bi)                          # (runs, B)
    if centre is None:
        w, _ = _normalize(lw_pred)
        xhat = (w[:, None, :] @ x_pred)                               # (runs, 1, d)
        centres = np.concatenate([xhat, xb], axis=1)                  # (runs, B+1, d)
        spreads = np.concatenate([spread[:, :1], spread], axis=1)
        lwc = np.concatenate([lwb[:, :1], lwb], axis=1)
    else:
        centres = np.broadcast_to(np.asarray(centre, float)[:, None, :], xb.shape)
        spreads, lwc = spread, lwb
    idx = np.arange(M) % centres.shape[1]
    # x2 = c + (eta r) s, computed in that order (the products and the sum of the printed form)
    x2 = eta * r
    x2 *= np.take(spreads, idx, axis=1)
    x2 += np.take(centres, idx, axis=1)
    return x2, np.take(lwc, idx, axis=1), idx


def _big_small(lw, n_big: int, off=None):
    """``(select_top_likelihood(lw, n_big), select_top_likelihood(-lw, n_big))`` -- the big particles
    largest first, the small ones smallest first -- from one ``argsort`` of ``lw``.

    Where the ``n_big + 1`` smallest and the ``n_big + 1`` largest values of every row are all
    distinct, both answers are unique (no tie at the boundary of either set, none inside), so
    any exact method gives them; otherwise (a tie, or NaN) it falls back to the two selections.
    ``off``: the row offsets ``M * arange(runs)[:, None]`` of the flattened ``lw``, if at hand.
    """
    runs, M = lw.shape
    # argsort puts NaN last, where the check below fails on it (NaN > v is False): no NaN pass
    order = np.argsort(lw, axis=1)                                    # increasing
    if off is None:
        off = (np.arange(runs) * M)[:, None]
    flat = lw.reshape(-1)
    lo = order[:, :n_big + 1]
    hi = order[:, M - n_big - 1:]
    vlo = np.take(flat, lo + off)
    vhi = np.take(flat, hi + off)
    if (vlo[:, 1:] > vlo[:, :-1]).all() and (vhi[:, 1:] > vhi[:, :-1]).all():
        return hi[:, :0:-1], lo[:, :n_big]
    return (select_top_likelihood(lw, n_big),
            select_top_likelihood(-np.where(np.isnan(lw), -np.inf, lw), n_big))


def _normalize(lw):
    """``w, collapsed`` of :func:`~pfrepro.filters.particle.normalize_log_weights` (the same numbers),
    with a lean path when every row has a finite maximum (and no log-normaliser)."""
    m = lw.max(axis=1, keepdims=True)
    if not np.isfinite(m).all():
        w, _, collapsed = normalize_log_weights(lw)
        return w, collapsed
    w = lw - m
    np.exp(w, out=w)
    w /= w.sum(axis=1, keepdims=True)
    return w, np.zeros(lw.shape[0], dtype=bool)


@dataclass
class CMSStep:
    """Internals of one CMS-PF step for one batch (Figs. 4-6 of the paper).

    ``x_pred``/``ll_pred`` (runs, N): predicted particles and log-likelihoods;
    ``x_map``/``ll_map`` (runs, N): map particles; ``selected`` (runs, N):
    indices into the pooled 2N candidates (< N: predicted, >= N: map);
    ``x``/``logw`` the selected particles and their normalised log-weights.
    """

    x_pred: np.ndarray
    ll_pred: np.ndarray
    x_map: np.ndarray
    ll_map: np.ndarray
    selected: np.ndarray
    x: np.ndarray
    logw: np.ndarray
    estimate: np.ndarray
    collapsed: np.ndarray | None = None


class CMSParticleFilter(Filter):
    """Chaos-map-sampling particle filter (Ning et al. 2011, sec 2.2 Steps 1-5, eqs 1, 3, 4, 6).

    Steps 2.1-2.5 of the module docstring: predict N particles, add N map particles
    x2 = c + r eta (big - small) with a chaotic carrier r (eq 1 or 6), keep the N of the
    2N with the highest likelihood, weight them by eq 3 (prior proposal), estimate by
    eq 4, resample when N_eff < N_th (Step 3).

    Parameters
    ----------
    model : StateSpaceModel
        Any model that can draw transitions and evaluate p(y | x).
    n_particles : int
        N >= 2 (the map adds N more candidates; N are kept).
    carrier : str or ChaosCarrier
        ``"logistic"`` (eq 1), ``"chebyshev"`` (eq 6) or ``"randn"``, or a
        :class:`~pfrepro.chaos.ChaosCarrier`.
    eta : float
        Adjustment factor eta/alpha (> 0); the paper finds 0.2-0.8 works.
    big_fraction : float
        n_big = max(1, round(big_fraction * N)) big (and small) particles, capped at N // 2.
    n_th : float
        Resampling threshold as a fraction of N (Step 3: resample when
        round(1/sum w^2) < n_th * N); ``0`` never resamples (the paper's CMS-PF of
        Table 3), ``1`` resamples at (almost) every step.
    resampling : str
        Scheme used in Step 3.
    m0, P0 : array_like, optional
        Override the model's prior p(x_0).

    Model methods
    -------------
    ``sample_transition``, ``log_likelihood``, ``m0``, ``P0``.

    Notes
    -----
    Diagnostics: ``ess`` (runs, T) after selection, ``resampled`` (runs, T),
    ``map_share`` (runs, T) fraction of the kept particles that are map particles,
    ``likelihood_evaluations`` per run (2 N T), ``collapsed`` (runs, T) / ``n_collapsed``: steps
    where every weight underflowed (weights reset to uniform; reported by one
    :class:`~pfrepro.filters.particle.WeightCollapseWarning` per call).
    """

    name = "CMS-PF"
    needs_rng = True

    def __init__(self, model, n_particles: int, carrier="logistic", eta: float = 0.5,
                 big_fraction: float = 0.1, n_th: float = 0.5, resampling: str = "systematic",
                 m0=None, P0=None):
        super().__init__(model, m0, P0)
        self.n_particles = check_positive_int(n_particles, "n_particles")
        if self.n_particles < 2:
            raise ValueError("CMSParticleFilter needs n_particles >= 2 (big and small particles)")
        self.carrier = carrier if isinstance(carrier, ChaosCarrier) else ChaosCarrier(carrier)
        self.eta = as_finite_float(eta, "eta (adjustment factor)", positive=True)
        self.big_fraction = check_probability(big_fraction, "big_fraction")
        self.n_big = int(min(max(1, round(self.big_fraction * self.n_particles)), self.n_particles // 2))
        self.n_th = check_probability(n_th, "n_th")
        self.resampling = check_scheme(resampling)

    # -- pieces --------------------------------------------------------------------------
    def step(self, x_prev, logw_prev, y_k, k: int, r, rng, x_true_k=None, use_map: bool = True) -> CMSStep:
        """One step (2.1-2.5, 4) on a batch; ``r`` (runs, N, d) carrier values.

        ``use_map=False`` skips 2.2-2.4 (a plain SIS step: the "without mapping"
        panels of Figs. 4-5).
        """
        N = self.n_particles
        x1 = self.model.sample_transition(x_prev, k, rng)
        ll1 = self.model.log_likelihood(y_k, x1)
        if not use_map:
            lw = logw_prev + ll1
            w, _, coll = normalize_log_weights(lw)
            with np.errstate(divide="ignore"):
                logw = np.log(w)
            est = (w[:, None, :] @ x1)[:, 0]
            return CMSStep(x1, ll1, x1[:, :0], ll1[:, :0], np.broadcast_to(np.arange(N), ll1.shape),
                           x1, logw, est, coll)
        centre = None if x_true_k is None else x_true_k
        lw1 = logw_prev + ll1
        x2, lw2_prev, _ = map_particles(x1, lw1, logw_prev, r, self.eta, self.n_big, centre)
        ll2 = self.model.log_likelihood(y_k, x2)
        xc = np.concatenate([x1, x2], axis=1)
        runs, M = ll1.shape[0], ll1.shape[1] + ll2.shape[1]
        # the key select_top_likelihood partitions, -[ll1 | ll2], written negated in one buffer
        neg = np.empty((runs, M))
        np.negative(ll1, out=neg[:, :N])
        np.negative(ll2, out=neg[:, N:])
        sel = _select_negated(neg, N)
        # w_{k-1} p(z_k | x) of the pool, added before the selection's gather (the same sums)
        lw2_prev += ll2
        lwc = np.concatenate([lw1, lw2_prev], axis=1)
        flat = sel + (np.arange(runs) * M)[:, None]          # one gather, not take_along_axis's
        x = np.take(xc.reshape(runs * M, -1), flat, axis=0)
        lw = np.take(lwc.reshape(-1), flat)
        w, coll = _normalize(lw)
        with np.errstate(divide="ignore"):
            logw = np.log(w)
        est = (w[:, None, :] @ x)[:, 0]
        return CMSStep(x1, ll1, x2, ll2, sel, x, logw, est, coll)

    # -- the filter ------------------------------------------------------------------------
    def _run(self, y, rng, x_true=None, r=None) -> FilterResult:
        runs, T, _ = y.shape
        N, n = self.n_particles, self.model.dim_x
        if r is None:
            carrier = self.carrier.generate(T, (runs, N, n), rng)   # offline carrier, (T, runs, N, n)
        else:
            carrier = np.asarray(r, dtype=float)
            if carrier.shape != (T, runs, N, n):
                raise ValueError(f"precomputed carrier r must have shape (T, runs, N, dim_x) = "
                                 f"{(T, runs, N, n)}, got {carrier.shape}")
            if not np.all(np.isfinite(carrier)):
                raise ValueError("precomputed carrier r contains NaN or inf")
        x = self.sample_prior(rng, (runs, self.n_particles))
        logw = np.full((runs, N), -np.log(N))
        xs = np.empty((runs, T, n))
        Ps = np.empty((runs, T, n, n))
        ess = np.empty((runs, T))
        resampled = np.zeros((runs, T), dtype=bool)
        map_share = np.empty((runs, T))
        collapsed = np.zeros((runs, T), dtype=bool)
        # likelihoods far in the tails over/underflow: handled in the log domain and recorded as
        # collapse (reported once below), so numpy's RuntimeWarnings are silenced at the source
        with np.errstate(over="ignore", under="ignore", divide="ignore", invalid="ignore"):
            self._loop(y, rng, x_true, carrier, x, logw, xs, Ps, ess, resampled, map_share, collapsed)
        n_collapsed = int(collapsed.sum())
        if n_collapsed:
            warn_collapse(self.name, n_collapsed, runs, T)
        return FilterResult(xs, Ps, diagnostics={
            "ess": ess, "resampled": resampled, "map_share": map_share, "collapsed": collapsed,
            "n_collapsed": n_collapsed, "likelihood_evaluations": 2 * N * T, "n_big": self.n_big})

    def _loop(self, y, rng, x_true, carrier, x, logw, xs, Ps, ess, resampled, map_share, collapsed):
        runs, T, _ = y.shape
        N, n = self.n_particles, self.model.dim_x
        counts_of = resampling_counts_function(self.resampling)
        for k in range(1, T + 1):
            if not np.all(np.isfinite(x)):
                raise FilterDivergenceError(f"{self.name} particles became non-finite at step {k}")
            xt = None if x_true is None else x_true[:, k]
            st = self.step(x, logw, y[:, k - 1], k, carrier[k - 1], rng, x_true_k=xt)
            x, logw = st.x, st.logw
            collapsed[:, k - 1] = st.collapsed
            w = np.exp(logw)
            xs[:, k - 1] = st.estimate
            d = x - st.estimate[:, None, :]
            Ps[:, k - 1] = np.einsum("rn,rni,rnj->rij", w, d, d)
            # the mean of a boolean row is its count over N: the same number, without a float copy
            map_share[:, k - 1] = np.count_nonzero(st.selected >= N, axis=1) / N
            neff = np.round(1.0 / np.sum(w * w, axis=1))              # Step 3
            ess[:, k - 1] = neff
            do = neff < self.n_th * N
            if do.all():
                # every run resamples: the streams of all runs (what take_runs would select), and
                # the weights normalised as resample_counts does (w is finite and positive here)
                counts = counts_of(w / w.sum(axis=1, keepdims=True), rng)
                x = np.repeat(x.reshape(-1, n), counts.ravel(), axis=0).reshape(runs, N, n)
                logw = np.full((runs, N), -np.log(N))
            elif do.any():
                sel = np.flatnonzero(do)
                ws = w[sel]
                full = np.ones((runs, N), dtype=np.intp)    # one copy of each particle elsewhere
                full[sel] = counts_of(ws / ws.sum(axis=1, keepdims=True), take_runs(rng, sel))
                x = np.repeat(x.reshape(-1, n), full.ravel(), axis=0).reshape(runs, N, n)
                logw = np.where(do[:, None], -np.log(N), logw)
            resampled[:, k - 1] = do

    def filter(self, y, rng: np.random.Generator | None = None, *, r=None) -> FilterResult:
        """Run on ``y`` (runs, T, dim_y). ``r``: optional carrier computed offline
        (``self.carrier.generate(T, (runs, N, dim_x), rng)``, shape (T, runs, N, dim_x))."""
        y = self._prepare(y, rng)
        return self._run(y, rng, r=r)

    def __repr__(self) -> str:
        return (f"{type(self).__name__}(N={self.n_particles}, carrier={self.carrier!r}, eta={self.eta}, "
                f"n_big={self.n_big}, n_th={self.n_th})")


class OracleCMSParticleFilter(CMSParticleFilter):
    """ORACLE -- not a filter: Step 2.2 read literally, map centred on the TRUE state x_k.

    Ning et al. 2011, Step 2.2 prints ``x2 = x_k + r eta (big - small)`` with x_k
    "the true state at time k". This class implements exactly that, so the book
    can show what the published numbers would need. It cannot run without the
    truth: :meth:`filter` requires ``x_true`` (``(runs, T + 1, d)`` as in
    ``Simulation.x``) and refuses to run otherwise. Map particles are spread over
    the ``n_big`` (big - small) pairs, all centred on the truth.

    Model methods
    -------------
    As :class:`CMSParticleFilter`.
    """

    name = "Oracle CMS-PF (uses the true state)"

    def filter(self, y, rng: np.random.Generator | None = None, *, x_true=None) -> FilterResult:
        if x_true is None:
            raise TypeError("OracleCMSParticleFilter uses the TRUE state and needs x_true=sim.x; "
                            "it is an oracle, not a filter -- use CMSParticleFilter for filtering")
        y = self._prepare(y, rng)
        xt = np.asarray(x_true, dtype=float)
        if xt.shape != (y.shape[0], y.shape[1] + 1, self.model.dim_x):
            raise ValueError(f"x_true must have shape (runs, T + 1, dim_x) = "
                             f"{(y.shape[0], y.shape[1] + 1, self.model.dim_x)}, got {xt.shape}")
        if not np.all(np.isfinite(xt)):
            raise ValueError("x_true contains NaN or inf")
        return self._run(y, rng, x_true=xt)
