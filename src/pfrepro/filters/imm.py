"""Interacting multiple model (IMM) filters, batched over runs, models and particles.

* :class:`IMMParticleFilter` -- the standard IMM particle filter (IMMPF) of Zhou, Sun, Chu
  & Cui (2017, sec 2, eqs 6-21), in the particle form of Boers & Driessen (2003) and
  McGinnity & Irwin (2000).
* :class:`IMMPFOR` -- Zhou et al.'s IMMPF with *optimisation resampling* (eqs 22-25):
  the particles that resampling would discard are replaced by new particles built from
  copy-group particles of all models.
* :class:`IMMKalman` -- the conventional IMM (Blom & Bar-Shalom 1988) with Kalman-family
  mode filters (KF, EKF or UKF from :mod:`pfrepro.filters`), the baseline a tracking
  engineer reaches for first; checked against filterpy's ``IMMEstimator``.

Our copy of Zhou et al. lost every displayed equation; the equations below are a
reconstruction from the paper's step names and its sources, each choice documented in
the class docstrings and in ``book/60_immpf.md``.

Conventions: the system is a :class:`~pfrepro.models.jump_markov.JumpMarkovSystem` with r modes and
transition matrix ``Pi[i, j] = P(m_k = j | m_{k-1} = i)`` (row = from, column = to), so
the predicted mode probabilities are ``c = mu @ Pi`` and the mixing probabilities are

    mu_{i|j} = Pi[i, j] mu_i / c_j                                          (eq 6)

stored as ``M[..., i, j]``. Particles are ``(runs, r, N, dim_x)``, log-weights
``(runs, r, N)``; the only Python loops are over time and over the r (a handful of) modes.
"""
from __future__ import annotations

import math
import threading

import numpy as np

from ..rng import take_runs
from ..validation import as_covariance, as_finite_float, as_vector, check_positive_int, check_probability

try:  # package v2 model contract
    from ..models.base import require_capabilities
except ImportError:  # pragma: no cover - before the contract existed
    require_capabilities = None
from .base import Filter, FilterDivergenceError, FilterResult, check_divergence_policy, gaussian_loglik, mark_diverged
from .kalman import symmetrize
from .particle import normalize_log_weights

__all__ = ["mixing_probabilities", "systematic_counts", "unit_ball_volume", "nn_distance_scale",
           "IMMParticleFilter", "IMMPFOR", "IMMKalman", "MODEL_LIKELIHOODS"]

#: the two readings of the model likelihood (eqs 14-15)
MODEL_LIKELIHOODS = ("gaussian", "mean")


def mixing_probabilities(mu, Pi):
    """Predicted mode probabilities ``c`` (..., r) and mixing probabilities ``M`` (..., r, r).

    ``c_j = sum_i Pi[i, j] mu_i`` and ``M[..., i, j] = mu_{i|j} = Pi[i, j] mu_i / c_j`` (eq 6),
    so every column of ``M`` sums to 1. A mode j that cannot be reached (c_j = 0) gets the
    column mu (it carries no probability, the value only keeps the arithmetic finite).
    """
    mu = np.asarray(mu, float)
    num = Pi * mu[..., :, None]
    # c_j = sum_i num[i, j] as a sum over the mode axis, not mu @ Pi: a BLAS matrix product's
    # rounding depends on how many rows (runs) it is given, so run i's probabilities would
    # differ in the last bit with the batch size (pfrepro.rng rule 3)
    c = num.sum(axis=-2)
    with np.errstate(invalid="ignore", divide="ignore"):
        M = num / c[..., None, :]
    zero = c <= 0
    if np.any(zero):
        M = np.where(zero[..., None, :], mu[..., :, None], M)
    return c, M


def _systematic_below(W, u, n_out: int, overwrite: bool = False):
    """Cumulative systematic counts ceil(n_out C_m - u) (..., M) as integers (see :func:`systematic_counts`).

    ``overwrite=True`` lets the float work happen in ``W`` itself (a float64 temporary of the caller).
    """
    Wn = np.divide(W, W.sum(axis=-1, keepdims=True), out=W if overwrite else None)
    Nc = np.cumsum(Wn, axis=-1, out=Wn)
    Nc *= n_out / Nc[..., -1:]
    Nc[..., -1] = n_out
    Nc -= u[..., None]
    np.ceil(Nc, out=Nc)
    # n_out C_m >= 0 and u < 1, so ceil(n_out C_m - u) >= -0.0, which converts to 0: no clipping
    return Nc.astype(np.intp)


def systematic_counts(W, u, n_out: int):
    """Systematic-resampling offspring counts over the last axis of ``W``.

    ``W`` (..., M) non-negative weights (normalised here), ``u`` (...) one uniform per row;
    returns integer counts (..., M) that sum to ``n_out`` per row: atom m gets
    ceil(n_out C_m - u) - ceil(n_out C_{m-1} - u) with C the cumulative weights
    (Kitagawa 1996). With ``n_out == M`` the arithmetic is that of
    :func:`pfrepro.filters.resampling.resample_counts` (bit for bit).
    """
    return _counts_from_below(_systematic_below(W, u, n_out))


def _counts_from_below(below):
    """Counts (..., M) from cumulative counts ``below`` (..., M): first entry, then differences."""
    counts = np.empty(below.shape, dtype=np.intp)
    counts[..., 0] = below[..., 0]
    np.subtract(below[..., 1:], below[..., :-1], out=counts[..., 1:])
    return counts


def _indices_from_below(below, n_out: int, base=None):
    """Ancestor indices (..., n_out) from cumulative counts ``below`` (..., M), non-decreasing rows
    ending at ``n_out`` (overwritten): slot s of a row belongs to the atom m with
    below[m-1] <= s < below[m], i.e. its index is #{m : below[m] <= s} (one bincount and one
    cumsum, no per-atom repeat). ``base`` (rows,) optional integers added to each row's indices."""
    lead, M = below.shape[:-1], below.shape[-1]
    rows = int(np.prod(lead)) if lead else 1
    b = below.reshape(rows, M)
    if rows and (b[:, -1] != n_out).any():
        raise ValueError(f"offspring counts must be non-negative and sum to n_out = {n_out} in every row")
    b += (np.arange(rows) * (n_out + 1))[:, None]
    hits = np.bincount(b.ravel(), minlength=rows * (n_out + 1)).reshape(rows, n_out + 1)[:, :n_out]
    if base is not None:
        hits[:, 0] += np.asarray(base, dtype=hits.dtype).reshape(rows)     # the cumsum carries it along the row
    return np.cumsum(hits, axis=1).reshape(lead + (n_out,))


def systematic_indices(W, u, n_out: int, overwrite: bool = False, base=None):
    """Ancestor indices (..., n_out), sorted per row, of systematic resampling over the last axis of
    ``W``: the atoms of :func:`systematic_counts` (same arithmetic), each repeated by its count,
    plus ``base`` (one integer per row, optional: e.g. the row's offset in a flat array)."""
    below = _systematic_below(W, u, n_out, overwrite)
    # n_out C_m can exceed n_out by a few ulps of rounding (< 1e-6), so ceil(n_out C_m - u) can
    # exceed n_out only when u < 1e-6, where the counts would turn negative: clip then
    if np.any(np.asarray(u) < 1e-6):
        np.minimum(below, n_out, out=below)
    return _indices_from_below(below, n_out, base)


def _indices_from_counts(counts):
    """Ancestor indices (..., n_out), sorted per row, from counts (..., M) whose rows sum to n_out."""
    lead, M = counts.shape[:-1], counts.shape[-1]
    rows = int(np.prod(lead)) if lead else 1
    n_out = int(counts.reshape(rows, M)[0].sum())
    if counts.size and counts.min() < 0:
        raise ValueError("offspring counts must be non-negative")
    return _indices_from_below(np.cumsum(counts, axis=-1), n_out)


def _put_rows(a, rows, values):
    """``a[rows] = values`` for a C-contiguous 2-D float array ``a`` (rows as opaque records: a
    plain byte copy per row, several times faster than numpy's row-wise fancy assignment)."""
    rec = np.dtype((np.void, a.shape[1] * a.itemsize))
    a.view(rec)[:, 0][rows] = np.ascontiguousarray(values, dtype=a.dtype).view(rec)[:, 0]


class _Work:
    """Work arrays reused across the time steps of one ``filter`` call (grown when a step needs more).

    The IMM particle filters' steps handle arrays of (runs, r N, n) floats, several MB each; freshly
    allocated at every step, such arrays are handed back to the system and re-mapped by the C
    allocator (glibc trims its heap above a threshold that follows the largest blocks), a page fault
    per 4 kB touched, every step. Reusing the same memory for the whole run avoids that; the
    arithmetic written into it is unchanged. A thread keeps the memory of its last call (up to
    ``KEEP_WORK_BYTES``) for its next one: freed and re-mapped at every call, it would move the
    page faults to whatever the process runs next (seen in the benchmark: the bootstrap PF measured
    after the IMM filters took 29 000 faults a call instead of about 1 000).
    """

    def __init__(self):
        self._arrays = {}

    @property
    def nbytes(self) -> int:
        """Bytes held."""
        return sum(a.nbytes for a in self._arrays.values())

    def get(self, name: str, shape, dtype=np.float64):
        """An uninitialised array of ``shape`` in the work memory ``name`` (valid until its next ``get``)."""
        size = math.prod(shape)
        a = self._arrays.get(name)
        if a is None or a.size < size or a.dtype != dtype:
            a = self._arrays[name] = np.empty(max(size, 1), dtype)
        return a[:size].reshape(shape)

    def other(self, x, shape):
        """Of the two work memories ``"x0"``/``"x1"``, an array of ``shape`` in the one ``x`` does not use
        (the particle sets of consecutive steps alternate between them)."""
        for name in ("x0", "x1"):
            a = self.get(name, shape)
            if not np.may_share_memory(a, x):
                return a
        raise AssertionError("unreachable: x overlaps both work memories")  # pragma: no cover


#: per thread: the work memory of each IMM particle filter whose ``filter`` call is under way
#: (``works``) and the work memory kept from the last call (``kept``)
_THREAD = threading.local()
#: a thread keeps the work memory of its last IMM particle-filter call for the next one up to this size
#: (the benchmark's 100 runs of 3 x 500 particles use about 67 MB; larger calls free theirs at the end)
KEEP_WORK_BYTES = 128 * 2**20


def _work_array(work, name, shape, dtype=np.float64):
    """``work.get(name, shape, dtype)``, or a new array when there is no work memory (``work=None``)."""
    return np.empty(shape, dtype) if work is None else work.get(name, shape, dtype)


def _take_rows(a, rows, out):
    """``out[...] = a[rows]`` for a C-contiguous float array ``a`` (M, n) and ``out`` (rows.shape + (n,)),
    each row moved as one opaque record (a byte copy per row: faster than numpy's float row gather).
    ``rows`` must be valid row indices (not checked: mode="clip" lets numpy take straight into ``out``;
    mode="raise" would gather into a temporary first)."""
    a = np.ascontiguousarray(a)
    rec = np.dtype((np.void, a.shape[-1] * a.itemsize))
    np.take(a.view(rec)[:, 0], rows, out=out.view(rec)[..., 0], mode="clip")
    return out


def _subtract_rows(a, v, out=None):
    """``a - v[..., None, :]`` for ``a`` (..., K, n) and ``v`` (..., n), bit for bit (the same subtractions).

    numpy's inner loop of the broadcast runs over the n numbers of one row; here g rows (g a
    divisor of K, at most 64) are taken as one row of g n numbers against v tiled g times, so the
    inner loop is g times longer: about twice as fast for n = 2..6. ``out`` optional (C-contiguous)."""
    *lead, K, n = a.shape
    g = max(d for d in range(1, min(K, 64) + 1) if K % d == 0)
    if out is None:
        out = np.empty(a.shape, np.result_type(a, v))
    shape = (*lead, K // g, g * n)
    np.subtract(np.ascontiguousarray(a).reshape(shape), np.tile(v, g)[..., None, :], out=out.reshape(shape))
    return out


def _var_axis1(a, work=None):
    """``np.var(a, axis=1)`` of ``a`` (R, K, n), bit for bit, faster when R > 1.

    numpy reduces a middle axis sequentially (row after row, vectorised over the n entries of a
    row); the same sums over axis 0 of the (K, R n) transposed copy run the identical sequence
    of additions with R n entries per row instead of n, several times faster. ``work`` (a
    :class:`_Work`, optional) holds the transposed copy."""
    R, K, n = a.shape
    if R == 1:
        return np.var(a, axis=1)
    t = _work_array(work, "var", (K, R, n))
    np.copyto(t, np.swapaxes(a, 0, 1))                                   # a copy: worked in place
    t = t.reshape(K, R * n)
    mean = np.add.reduce(t, axis=0, keepdims=True)
    mean /= K
    np.subtract(t, mean, out=t)
    np.multiply(t, t, out=t)
    out = np.add.reduce(t, axis=0)
    out /= K
    return out.reshape(R, n)


def _check_keep_steps(keep_steps) -> tuple:
    """``keep_steps`` of the IMM particle filters: increasing steps >= 1, as a tuple of ints."""
    if keep_steps is None:
        return ()
    if isinstance(keep_steps, (str, bytes)) or not np.iterable(keep_steps):
        raise TypeError(f"keep_steps must be a sequence of steps (int >= 1), got {keep_steps!r}")
    steps = tuple(check_positive_int(k, "keep_steps entry") for k in keep_steps)
    if any(b <= a for a, b in zip(steps[:-1], steps[1:])):
        raise ValueError(f"keep_steps must be strictly increasing, got {steps}")
    return steps


def _init_on_system(filt, system, m0, P0, mode_requirements):
    """Filter set-up on a jump-Markov system: every mode model must meet the model contract.

    (``Filter.__init__`` checks a single StateSpaceModel; an IMM's model is the system.)
    """
    if not (hasattr(system, "models") and hasattr(system, "Pi")):
        raise TypeError(f"{type(filt).__name__} needs a pfrepro.models.JumpMarkovSystem, got {type(system).__name__}")
    if require_capabilities is not None:
        for j, m in enumerate(system.models):
            require_capabilities(m, mode_requirements, f"{type(filt).__name__} (mode {j})")
    filt.model = filt.system = system
    filt.m0 = system.m0 if m0 is None else as_vector(m0, "m0", system.dim_x)
    filt.P0 = system.P0 if P0 is None else as_covariance(P0, "P0", system.dim_x)


def _check_mode_filter_model(f, system, j):
    """Mode filter j must be built on mode j's model (issue 21: one built on another mode's
    model ran and was silently wrong). The same object passes; another object passes only if
    it has mode j's Q and transition f at a few probe states."""
    fm, mj = getattr(f, "model", None), system.models[j]
    if fm is mj or fm is None:
        return
    same = getattr(fm, "dim_x", None) == mj.dim_x
    if same:
        probe = np.asarray(system.m0, float) + np.arange(1, 4)[:, None] * np.linspace(0.5, 1.5, mj.dim_x)
        try:
            same = (np.allclose(np.asarray(fm.Q), np.asarray(mj.Q), rtol=1e-12, atol=0)
                    and np.allclose(fm.f(probe, 1), mj.f(probe, 1), rtol=1e-12, atol=1e-12))
        except Exception:  # noqa: BLE001 - a model we cannot compare is treated as different
            same = False
    if not same:
        name = system.names[j] if hasattr(system, "names") else j
        raise ValueError(f"mode_filters[{j}] is built on a model that is not mode {j}'s ({name!r}): build it "
                         f"on system.models[{j}]")


def unit_ball_volume(d: int) -> float:
    """Volume V_d = pi^(d/2) / Gamma(d/2 + 1) of the unit ball in d dimensions."""
    d = check_positive_int(d, "d")
    return math.pi ** (d / 2) / math.gamma(d / 2 + 1)


def nn_distance_scale(n: float, density, d: int):
    """Theorem 1 of Zhou et al. (eq 22): mean nearest-neighbour distance of n samples from p.

    E[R] = Gamma(1 + 1/d) / (n p(x) V_d)^(1/d), the mean distance from a point to its
    nearest neighbour in a Poisson field of intensity n p(x) in d dimensions
    (Bhattacharyya & Chakrabarti); ``density`` may be an array.
    """
    d = check_positive_int(d, "d")
    n = as_finite_float(n, "n", positive=True)
    density = np.asarray(density, float)
    return math.gamma(1.0 + 1.0 / d) / (n * density * unit_ball_volume(d)) ** (1.0 / d)


class IMMParticleFilter(Filter):
    """Standard IMM particle filter (IMMPF), Zhou et al. (2017) sec 2, eqs 6-21 (reconstructed).

    Per step k (modes j = 1..r, N particles each, ``w`` the weights of step k-1):

    1. *Interaction* (eqs 6-7). mu_{i|j} = Pi[i, j] u_i(k-1) / c_j. Mode j draws N
       equally weighted particles from the mixture sum_i mu_{i|j} sum_l w_l^i delta(x - x_l^i)
       by systematic resampling over all r N atoms (Boers & Driessen 2003: "mode j takes
       its particles from mode i with probability mu_{i|j}"). Skipped at k = 1, where all
       modes hold draws from the same prior N(m0, P0) and mixing changes nothing.
    2. *Prediction* (eq 8): x_l^j ~ p_j(x_k | x_l^j) (the mode's transition prior).
    3. *Residuals* (eqs 9-12): z_hat_l = h(x_l), eps_l = z_k - z_hat_l (bearing wrapped),
       residual mean eps_bar^j = sum_l w_l eps_l (11) and spread
       sum_l w_l (eps_l - eps_bar)(eps_l - eps_bar)^T (12).
    4. *Particle likelihood* (eq 13): p_l = N(eps_l; 0, R).
    5. *Model likelihood* (eqs 14-15), two readings (``model_likelihood``):

       * ``"gaussian"`` (default, what the names of eqs 11-15 suggest):
         S^j = R + spread (14), Lambda_j = N(eps_bar^j; 0, S^j) (15) -- a Gaussian
         (moment-matched) approximation of p(z_k | m_k = j, z_1:k-1), as in a Kalman IMM;
       * ``"mean"`` (Boers & Driessen 2003): Lambda_j = sum_l w_l p_l, the Monte Carlo
         estimate of the same predictive density.
    6. *Model probabilities* (eq 16): u_j(k) = Lambda_j c_j / sum_i Lambda_i c_i.
    7. *Weights* (eqs 17-18): w_l proportional to w_l p_l, normalised per mode (log domain).
    8. *Resampling* (eq 19): N_eff = 1 / sum_l w_l^2 per mode; the modes with
       N_eff < ``n_th`` N are resampled (systematic), weights reset to 1/N.
       (:class:`IMMPFOR` replaces this step.)
    9. *Estimates* (eqs 20-21), from the particles after step 8, in the paper's order:
       x_hat^j = sum_l w_l x_l, x_hat = sum_j u_j x_hat^j.

    Parameters
    ----------
    system : JumpMarkovSystem
        The mode models, Pi and initial probabilities
        (:class:`~pfrepro.models.jump_markov.JumpMarkovSystem`).
    n_particles : int
        N >= 1 per mode (r N in all).
    model_likelihood : {"gaussian", "mean"}
        The reading of the model likelihood (step 5).
    n_th : float
        Resampling threshold as a fraction of N (N_th = n_th N), in [0, 1]; 0 never resamples
        in step 8 (the interaction of the next step still draws a fresh set).
    m0, P0 : ndarray, optional
        Override the initial distribution N(m0, P0) shared by every mode.
    keep_steps : sequence of int, optional
        Steps k (1-based, increasing) at which the posterior particle sets are kept: after
        step 8, the particles and weights that step 9's estimates use, in the diagnostics
        ``particles`` (runs, S, r, N, dim_x) and ``particle_weights`` (runs, S, r, N); with
        ``mode_probs`` they are the whole particle approximation of the posterior (used to
        measure its distance to a large-N reference). Default: none kept.

    Notes
    -----
    With r = 1 (Pi = [[1]]) and ``n_th = 0`` this is the bootstrap PF with systematic
    resampling at every step (same random numbers and arithmetic, up to the last bits of the
    likelihood; ``tests/test_imm.py``).

    Diagnostics: ``mode_probs`` (runs, T, r); ``model_estimates`` (runs, T, r, dim_x);
    ``log_model_likelihood`` (runs, T, r); ``ess`` (runs, T, r) before resampling;
    ``resampled`` (runs, T, r); ``collapsed`` (runs, T, r) (every weight of a mode underflowed);
    ``likelihood_evals`` and ``density_evals`` (runs,): deterministic cost counts.
    """

    name = "IMMPF"
    needs_rng = True

    #: what every mode model must provide (the model contract)
    model_requirements = ("transition_sampler", "additive_measurement")

    def __init__(self, system, n_particles: int, model_likelihood: str = "gaussian", n_th: float = 0.5,
                 m0=None, P0=None, keep_steps=None):
        _init_on_system(self, system, m0, P0, self.model_requirements)
        self.n_particles = check_positive_int(n_particles, "n_particles")
        self.keep_steps = _check_keep_steps(keep_steps)
        if model_likelihood not in MODEL_LIKELIHOODS:
            raise ValueError(f"model_likelihood must be one of {MODEL_LIKELIHOODS}, got {model_likelihood!r}")
        self.model_likelihood = model_likelihood
        self.n_th = check_probability(n_th, "n_th")
        noise = system.measurement_noise
        if hasattr(noise, "components") or np.any(getattr(noise, "mean", 0.0) != 0):
            self._meas_whiten = None          # mixture / non-zero mean: use the noise's own logpdf
        else:
            Lr = np.linalg.cholesky(noise.cov)
            self._meas_whiten = np.linalg.inv(Lr).T
            self._meas_lognorm = -0.5 * noise.cov.shape[0] * np.log(2 * np.pi) - np.sum(np.log(np.diag(Lr)))

    def particle_log_likelihood(self, eps):
        """Eq 13: log N(eps; 0, R) for residuals ``eps`` (runs, r, N, m)."""
        if self._meas_whiten is None:
            return self.system.measurement_noise.logpdf(eps)
        z = eps @ self._meas_whiten                       # stacked matmul (no tall 2-D BLAS call)
        q = np.einsum("...i,...i->...", z, z)
        q *= -0.5
        q += self._meas_lognorm
        return q

    def resample_mask(self, ess, N: int):
        """Eq 19: which (run, mode) rows are resampled, from their N_eff (runs, r): N_eff < N_th."""
        return ess < self.n_th * N

    # -- inner steps (each is tested on a hand-computed case) ------------------------------------
    def interact(self, x, w, mu, rng):
        """Eqs 6-7: for each mode j, N equally weighted particles from sum_i mu_{i|j} sum_l w_l^i delta.

        ``x`` (runs, r, N, n), ``w`` (runs, r, N) normalised per mode, ``mu`` (runs, r).
        Draws ``rng.random((runs, r))`` (one systematic offset per run and target mode).
        Returns the new particles and the mixing matrix M[run, i, j] = mu_{i|j}.
        """
        runs, r, N, n = x.shape
        _, M = mixing_probabilities(mu, self.system.Pi)
        # atom weights of the mixture for target j: W[run, j, i, l] = mu_{i|j} w_l^i
        W = np.swapaxes(M, 1, 2)[..., None] * w[:, None, :, :]
        u = rng.random((runs, r))
        # (runs, r, N) flat particle indices: the run's offset plus the atom among its r N particles
        base = np.repeat(np.arange(runs) * (r * N), r)
        idx = systematic_indices(W.reshape(runs, r, r * N), u, N, overwrite=True, base=base)
        if self._work is None:
            return np.take(x.reshape(-1, n), idx, axis=0), M                     # (take: a fast row gather)
        # into the work memory x does not use
        return _take_rows(x.reshape(-1, n), idx, self._work.other(x, (runs, r, N, n))), M

    def model_log_likelihood(self, eps, logw, loglik):
        """Eqs 11-15: log Lambda_j (runs, r) from residuals ``eps`` (runs, r, N, m), previous log-weights.

        ``logw=None`` means uniform weights 1/N (the filter's case: after the interaction every
        particle weighs 1/N), with the same arithmetic as ``logw = full(-log N)``.
        """
        N = eps.shape[-2]
        if self.model_likelihood == "mean":
            a = loglik + (-np.log(N)) if logw is None else logw + loglik
            m = np.max(a, axis=-1, keepdims=True)
            m = np.where(np.isfinite(m), m, 0.0)
            with np.errstate(divide="ignore"):
                return (m[..., 0] + np.log(np.sum(np.exp(a - m), axis=-1)))
        if logw is None:
            # exp(logw - max) = 1 exactly and the N ones sum to N exactly: the weights are 1.0 / N
            w = np.full(eps.shape[:-1], 1.0 / N)
            ebar = (w[..., None, :] @ eps)[..., 0, :]                            # (11)
            dw = _subtract_rows(eps, ebar)                                       # eps - ebar
            dw *= math.sqrt(1.0 / N)                                             # d sqrt(w), in place
        else:
            w = np.exp(logw - logw.max(axis=-1, keepdims=True))
            w /= w.sum(axis=-1, keepdims=True)
            ebar = (w[..., None, :] @ eps)[..., 0, :]                            # (11)
            d = eps - ebar[..., None, :]
            dw = d * np.sqrt(w)[..., None]
        S = self.system.R + np.swapaxes(dw, -1, -2) @ dw                         # (12) + (14)
        return gaussian_loglik(ebar, S)                                          # (15)

    @staticmethod
    def update_mode_probabilities(c, log_lik):
        """Eq 16: u_j proportional to Lambda_j c_j, from log Lambda (runs, r) (log domain)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            a = log_lik + np.log(c)
            a = np.where(np.isnan(a), -np.inf, a)
            top = np.max(a, axis=-1, keepdims=True)
            # every model likelihood underflowed (or is NaN): keep the predicted probabilities c
            dead = ~np.isfinite(top)
            a = np.where(dead, np.log(np.maximum(c, 1e-300)), a - np.where(dead, 0.0, top))
        u = np.exp(a)
        return u / u.sum(axis=-1, keepdims=True)

    def _resample(self, x, w, do, u_next, M_next, rng, k, cost):
        """Eq 19: systematic resampling of the modes with ``do`` (runs, r); IMMPFOR overrides."""
        runs, r, N, n = x.shape
        sel = np.flatnonzero(do.any(axis=1))
        if sel.size == 0:
            return x, w, np.zeros((runs, r), dtype=np.intp)
        uu = take_runs(rng, sel).random((sel.size, r))
        # only the (run, mode) rows that resample: each row's counts use its own weights and offset
        a, j = np.nonzero(do)
        if a.size:
            flat = x.reshape(-1, n)
            anc = systematic_indices(w[a, j], uu[np.searchsorted(sel, a), j], N, overwrite=True, base=(a * r + j) * N)
            x[a, j] = np.take(flat, anc, axis=0)
        w = w.copy()
        w[do] = 1.0 / N
        return x, w, np.zeros((runs, r), dtype=np.intp)

    @property
    def _work(self):
        """The work memory (:class:`_Work`) of this filter's ``filter`` call under way in this thread, or
        None (a call of a step method outside ``filter``: its arrays are allocated afresh)."""
        return getattr(_THREAD, "works", {}).get(id(self))

    # -- the recursion -------------------------------------------------------------------------------
    def filter(self, y, rng=None) -> FilterResult:
        # the large arrays of a step live in work memory reused by every step of this call; it is
        # the thread's own (one filter object may run in several threads at once), kept for the
        # thread's next call up to KEEP_WORK_BYTES
        works = _THREAD.__dict__.setdefault("works", {})
        key = id(self)
        outer = works.get(key)             # (a call from within a call gets its own, then gives it back)
        # the work memory the thread's last call kept, taken for this call (a nested call gets new memory)
        work = _THREAD.__dict__.pop("kept", None) or _Work()
        works[key] = work
        try:
            return self._filter(y, rng)
        finally:
            if outer is None:
                del works[key]
            else:
                works[key] = outer
            if work.nbytes <= KEEP_WORK_BYTES:
                _THREAD.kept = work

    def _filter(self, y, rng) -> FilterResult:
        y = self._prepare(y, rng)
        runs, T, _ = y.shape
        sysm = self.system
        r, N, n = sysm.r, self.n_particles, sysm.dim_x
        x = self.sample_prior(rng, (runs, r, N))
        # the weights entering every step are uniform (the prior at k = 1, the interaction's
        # equally weighted draws after): log w = -log N, passed on as ``None``/a scalar
        lognorm = -np.log(N)
        w = np.full((runs, r, N), 1.0 / N)
        mu = np.broadcast_to(sysm.initial_probs, (runs, r)).copy()
        xs = np.empty((runs, T, n))
        xj = np.empty((runs, T, r, n))
        probs = np.empty((runs, T, r))
        loglam = np.empty((runs, T, r))
        ess = np.empty((runs, T, r))
        resampled = np.zeros((runs, T, r), dtype=bool)
        collapsed = np.zeros((runs, T, r), dtype=bool)
        replaced = np.zeros((runs, T, r), dtype=np.intp)
        cost = {"likelihood": np.zeros(runs, dtype=np.int64), "density": np.zeros(runs, dtype=np.int64)}
        keep = {k: i for i, k in enumerate(self.keep_steps)}
        if self.keep_steps and self.keep_steps[-1] > T:
            raise ValueError(f"keep_steps: step {self.keep_steps[-1]} is beyond the T = {T} steps of y")
        kept_x = np.empty((runs, len(keep), r, N, n))
        kept_w = np.empty((runs, len(keep), r, N))
        for k in range(1, T + 1):
            c, _ = mixing_probabilities(mu, sysm.Pi)
            if k > 1:
                x, _ = self.interact(x, w, mu, rng)
            for j, m in enumerate(sysm.models):                                   # (8)
                x[:, j] = m.sample_transition(x[:, j], k, rng)
            if not (np.isfinite(x.min()) and np.isfinite(x.max())):              # (min/max propagate NaN)
                raise FilterDivergenceError(f"{self.name}: particles became non-finite at step {k}")
            yk = y[:, k - 1][:, None, None, :]
            eps = sysm.residual_y(yk, sysm.h(x))                                 # (9)-(10)
            ll = self.particle_log_likelihood(eps)                                # (13)
            cost["likelihood"] += r * N
            lam = self.model_log_likelihood(eps, None, ll)                        # (11)-(15)
            u = self.update_mode_probabilities(c, lam)                            # (16)
            w, _, coll = normalize_log_weights((ll + lognorm).reshape(runs * r, N))  # (17)-(18)
            w = w.reshape(runs, r, N)
            collapsed[:, k - 1] = coll.reshape(runs, r)
            e = 1.0 / np.sum(w * w, axis=-1)                                      # (19)
            ess[:, k - 1] = e
            do = self.resample_mask(e, N)
            _, M_next = mixing_probabilities(u, sysm.Pi)
            x, w, nrep = self._resample(x, w, do, u, M_next, rng, k, cost)
            resampled[:, k - 1] = do
            replaced[:, k - 1] = nrep
            if k in keep:
                kept_x[:, keep[k]] = x
                kept_w[:, keep[k]] = w
            est = np.einsum("arn,arni->ari", w, x)                                # (20)
            xj[:, k - 1] = est
            xs[:, k - 1] = np.einsum("ar,ari->ai", u, est)                        # (21)
            probs[:, k - 1] = u
            loglam[:, k - 1] = lam
            mu = u
        return FilterResult(xs, None, diagnostics={
            "mode_probs": probs, "model_estimates": xj, "log_model_likelihood": loglam, "ess": ess,
            "resampled": resampled, "collapsed": collapsed, "n_collapsed": int(collapsed.sum()),
            "replaced": replaced, "likelihood_evals": cost["likelihood"], "density_evals": cost["density"],
            **({"particles": kept_x, "particle_weights": kept_w} if keep else {})})

    def __repr__(self) -> str:
        return (f"{type(self).__name__}(r={self.system.r}, N={self.n_particles}, "
                f"model_likelihood={self.model_likelihood!r}, n_th={self.n_th})")


class IMMPFOR(IMMParticleFilter):
    """IMMPF with optimisation resampling, Zhou et al. (2017) eqs 22-25 (reconstructed).

    Steps 1-7 and 9 are those of :class:`IMMParticleFilter`; step 8 (resampling of the
    modes with N_eff < N_th) becomes:

    a. *Copy and discard groups* (text, step 6): systematic resampling of mode j's weights;
       particles with at least one offspring form the copy group, particles with none the
       discard group S^j. Its size is set by the weights (not a free parameter).
    b. *Slots*: the resampled set holds, besides one copy of each copy-group particle,
       ``|S^j|`` extra copies; the m-th extra-copy slot (in slot order) is paired with the m-th
       discarded particle x_s (in index order) and gets the new particle, eq (23).
    c. *Joint normalisation* (eq 24): w'_l^j = u_j(k) w_l^j over all r N particles (sums to 1);
       their weighted mean m and covariance C define the metric: distances are measured in
       whitened coordinates z = L^{-1}(x - m), C = L L^T (our choice: the paper's Euclidean
       distance mixes metres, m/s and m/s^2), and p(x) is the moment-matched Gaussian
       density of the jointly normalised set, N(z; 0, I) in z.
    d. *Step* (eqs 22, 25): L_a = Gamma(1 + 1/n) / (r N p(z_a) V_n)^(1/n) at each copy
       particle x_a (Theorem 1 with the r N particles of the joint set).
    e. *New particle* (eq 23): with parents x_a^j (the slot's own copy) and, for i != j,
       x_a^i = a particle of mode i's resampled set at a uniformly drawn slot (a draw from
       mode i's copy group by weight),

           z_n^j = sum_i mu_{i|j}(k|k) [ z_a^i + d L_{a^i} (z_s - z_a^i) / ||z_s - z_a^i|| ],

       i.e. each parent moves one neighbour spacing (times d) towards the discarded
       particle, and the moved parents are mixed across modes by the mixing
       probabilities of the next interaction (computed from u(k), as the paper's
       step 3 does). The unit vector is our reading of "d removes the effect of the
       Euclidean distance between x_a and x_s".
    f. All weights of a resampled mode become 1/N.

    Parameters (besides IMMPF's): ``d`` the step coefficient (> 0, default 1: one neighbour
    spacing). Three readings of what the lost equations fixed (``book/60_immpf.md``):

    * ``replace`` -- ``"threshold"`` (default): steps a-f only in the modes with
      N_eff < N_th (eq 19, as the IMMPF resamples); ``"always"``: in every mode at every
      step (the paper's steps 6-7 name no threshold).
    * ``density`` -- p(x) in eq 25: ``"gaussian"`` (default) the moment-matched density
      N(z; 0, I) of step c; ``"weights"``: the joint weight w' itself (eq 24) taken as p(x),
      as the prose around eq 25 reads.
    * ``metric`` -- the distance of steps c-e: ``"whitened"`` (default) z = L^{-1}(x - m) with
      the full jointly weighted covariance C = L L^T; ``"diagonal"``: each component scaled
      by its own weighted standard deviation only, z = D^{-1}(x - m), D = diag(C)^(1/2)
      (correlations ignored; the Gaussian density of step c is then N(z; 0, D^{-1} C D^{-1})).
    * ``mix_modes`` -- ``True`` (default) eq 23 as above; ``False`` (an ablation, not a
      reading): only the slot's own parent x_a^j moves, z_n = z_a^j + step, no mixing
      across modes.

    Cost: the density p is evaluated once at each of the r N particles of a run
    at every step where one of its modes resamples (``density_evals``); no extra
    likelihood evaluations.
    """

    name = "IMMPFOR"

    #: readings of eq 25's density p(x) and of when the replacement runs
    DENSITIES = ("gaussian", "weights")
    REPLACE = ("threshold", "always")
    METRICS = ("whitened", "diagonal")

    def __init__(self, system, n_particles: int, model_likelihood: str = "gaussian", n_th: float = 0.5,
                 d: float = 1.0, m0=None, P0=None, density: str = "gaussian", replace: str = "threshold",
                 mix_modes: bool = True, metric: str = "whitened", keep_steps=None):
        super().__init__(system, n_particles, model_likelihood, n_th, m0, P0, keep_steps)
        if metric not in self.METRICS:
            raise ValueError(f"metric must be one of {self.METRICS}, got {metric!r}")
        self.metric = metric
        if isinstance(d, (str, bytes, bool, np.bool_)) or not isinstance(d, (int, float, np.integer, np.floating)):
            raise TypeError(f"step coefficient d must be a positive number, got {d!r}")
        d = float(d)
        if not (np.isfinite(d) and d > 0):
            raise ValueError(f"step coefficient d must be a positive number, got {d!r}")
        if density not in self.DENSITIES:
            raise ValueError(f"density must be one of {self.DENSITIES}, got {density!r}")
        if replace not in self.REPLACE:
            raise ValueError(f"replace must be one of {self.REPLACE}, got {replace!r}")
        self.d = d
        self.density = density
        self.replace = replace
        self.mix_modes = bool(mix_modes)

    def resample_mask(self, ess, N: int):
        """Which (run, mode) rows get steps a-f: N_eff < N_th, or all of them (``replace="always"``)."""
        if self.replace == "always":
            return np.ones(np.shape(ess), dtype=bool)
        return super().resample_mask(ess, N)

    @staticmethod
    def joint_whitening(x, w, u, work=None):
        """Eq 24: joint weights w' = u_j w_l^j; returns (mean (R, n), lower Cholesky L (R, n, n), z).

        ``work`` (optional, a ``filter`` call's work memory): z and the temporaries of the
        (R, r N, n) size are written into it (z is then valid until the next step)."""
        R_, r, N, n = x.shape
        wj = (u[:, :, None] * w).reshape(R_, r * N)
        wj = wj / wj.sum(axis=1, keepdims=True)
        flat = x.reshape(R_, r * N, n)
        m = (wj[:, None, :] @ flat)[:, 0]
        dev = _subtract_rows(flat, m, out=_work_array(work, "dev", flat.shape))
        dw = np.multiply(dev, wj[..., None], out=_work_array(work, "z", flat.shape))
        C = np.swapaxes(dw, -1, -2) @ dev
        # regularisation: the weighted covariance is singular when the weight sits on a few
        # particles (or on copies of one); add 1e-6 of the unweighted spread of all r N particles
        # (never degenerate: every mode's prediction adds noise) plus an absolute floor
        spread = _var_axis1(flat, work)
        C = C + np.einsum("ai,ij->aij", 1e-6 * spread + 1e-12, np.eye(n))
        L = np.linalg.cholesky(C)
        Linv = np.linalg.inv(L)
        z = np.matmul(dev, np.swapaxes(Linv, -1, -2), out=dw)                      # (dw is spent)
        return m, L, z.reshape(R_, r, N, n)

    def replacement(self, x, w, u, M, counts, other_slots, do=None, idx=None, out=None):
        """Eqs 22-25 for the modes of ``R`` runs; returns the new particle sets (R, r, N, n) and ``|S^j|``.

        ``x`` (R, r, N, n) particles after weighting, ``w`` (R, r, N) their weights, ``u`` (R, r)
        the model probabilities, ``M`` (R, r, r) the mixing probabilities mu_{i|j}(k|k),
        ``counts`` (R, r, N) systematic offspring counts of every mode, ``other_slots``
        (R, r, N) uniform slot indices that pick the parents x_a^i, i != j; ``do`` (R, r)
        the modes to resample (default all). Modes not in ``do`` are returned unchanged.
        ``idx`` (R, r, N) optional: the ancestor indices of ``counts`` if the caller has them;
        ``out`` (R, r, N, n) optional, C-contiguous: the array to write the new sets into; ``out=x``
        replaces them in ``x`` itself (only the modes in ``do`` are written).
        Only the extra-copy slots are computed (flat arrays over all of them at once).
        """
        R_, r, N, n = x.shape
        if out is not None and not (isinstance(out, np.ndarray) and out.shape == x.shape and out.dtype == np.float64
                                    and out.flags.c_contiguous):
            raise ValueError(f"out must be a C-contiguous float64 array of the shape of x {x.shape}")
        do = np.ones((R_, r), dtype=bool) if do is None else np.asarray(do, bool)
        M = np.asarray(M, dtype=float)
        work = self._work
        m, L, z = self.joint_whitening(x, w, u, work)                             # (24)
        if self.metric == "diagonal":      # scale by the standard deviations only (L = D Lc)
            sd = np.sqrt(np.einsum("aii->ai", L @ np.swapaxes(L, -1, -2)))          # (R, n)
            Lc = L / sd[:, :, None]                                                # Cholesky of D^-1 C D^-1
            z = np.einsum("aij,arnj->arni", Lc, z)                                 # D^-1 (x - m)
            L = np.einsum("ai,ij->aij", sd, np.eye(n))
            logdet = np.sum(np.log(np.einsum("aii->ai", Lc)), axis=1)[:, None, None]
        else:
            Lc, logdet = None, None
        if self.density == "weights":      # p(x) = w' = u_j w_l^j, the jointly normalised weight (24)
            wj = u[:, :, None] * w
            with np.errstate(divide="ignore"):
                logstep = np.log(wj / wj.sum(axis=(1, 2), keepdims=True))
        else:                              # the moment-matched Gaussian of the w'-weighted set
            zw = z if Lc is None else np.einsum("aij,arnj->arni", np.linalg.inv(Lc), z)
            # log p = -0.5 z.z - 0.5 n log(2 pi) - log det, in place (the whitened metric's log det is 0)
            logstep = np.einsum("arni,arni->arn", zw, zw, out=_work_array(work, "logstep", (R_, r, N)))
            logstep *= -0.5
            logstep -= 0.5 * n * np.log(2 * np.pi)
            if logdet is not None:
                logstep -= logdet
        # (22), (25) in place, in the order of log L = lgamma(1 + 1/n) - (log(r N) + log p + log V_n) / n,
        # then log d + log L (sums and products of two numbers commute bit for bit)
        logstep += np.log(r * N)
        logstep += np.log(unit_ball_volume(n))
        logstep /= n
        np.subtract(math.lgamma(1 + 1 / n), logstep, out=logstep)
        np.add(np.log(self.d), logstep, out=logstep)                             # (R, r, N) per particle
        if idx is None:
            idx = _indices_from_counts(counts)                                   # (R, r, N) ancestors
        if out is x:                       # in place: only the sets of the modes in do move
            a_do, j_do = np.nonzero(do)
            rows = a_do * r + j_do                                                # flat (run, mode) rows
            sets = _take_rows(x.reshape(-1, n), idx[a_do, j_do] + (rows * N)[:, None],
                              _work_array(work, "sets", (rows.size, N, n)))
            _put_rows(x.reshape(R_ * r, N * n), rows, sets.reshape(rows.size, N * n))
        else:
            rowbase = (np.arange(R_)[:, None] * r + np.arange(r)) * N             # (R, r) flat row offsets
            # the standard resampled sets of the modes in do, the others unchanged: one row gather
            src = np.where(do[..., None], idx, np.arange(N)) + rowbase[..., None]
            if out is None:
                out = np.empty((R_, r, N, n))
            _take_rows(x.reshape(-1, n), src, out)                                # (R, r, N, n), C order
        is_disc = counts == 0
        n_disc = is_disc.sum(axis=-1)                                             # |S^j| = number of extra copies
        is_dup = np.zeros((R_, r, N), dtype=bool)
        np.equal(idx[..., 1:], idx[..., :-1], out=is_dup[..., 1:])
        is_dup &= do[..., None]
        # K extra-copy slots, as flat indices into (R, r, N) (C order: by row, then slot)
        f = np.flatnonzero(is_dup)
        K = f.size
        if K == 0:
            return out, n_disc
        # m-th extra copy (slot order) <-> m-th discarded particle (index order): a row has as many
        # extra copies as discarded particles, so the two flat C-order lists pair up one to one
        is_disc &= do[..., None]
        z_flat = z.reshape(-1, n)
        z_s = _take_rows(z_flat, np.flatnonzero(is_disc), _work_array(work, "z_s", (K, n)))
        row = f // N                                                              # flat (run, mode) row
        A, J = np.divmod(row, r)
        idx_flat = idx.reshape(-1)
        logstep_flat = logstep.reshape(-1)
        AN = A * (r * N)                                                          # rowbase[A, i] = AN + i N
        other_pos = np.take(other_slots.reshape(-1), f)
        other_pos += AN                                                           # slot of mode i: + i N
        M_flat = M.reshape(-1)
        AJ = A * (r * r) + J                                                      # M[A, i, J] at AJ + i r
        new = _work_array(work, "new", (K, n))
        new.fill(0.0)
        z_a, dv = _work_array(work, "z_a", (K, n)), _work_array(work, "dv", (K, n))
        pos, par = _work_array(work, "pos", (K,), np.intp), _work_array(work, "par", (K,), np.intp)
        lam, tmp = _work_array(work, "lam", (K,)), _work_array(work, "tmp", (K,))
        for i in range(r):
            # parent from mode i: the slot's own copy (i == j: at the slot f itself) or a uniformly
            # drawn slot of mode i; par = the flat index of x_a^i
            own = J == i
            np.add(other_pos, i * N, out=pos)
            np.copyto(pos, f, where=own)
            np.take(idx_flat, pos, out=par, mode="clip")
            par += AN
            par += i * N
            _take_rows(z_flat, par, z_a)
            np.subtract(z_s, z_a, out=dv)
            dist = np.einsum("ki,ki->k", dv, dv, out=lam)
            np.sqrt(dist, out=dist)
            # fraction of the way to x_s: d L / ||z_s - z_a||, capped at 1 (never past x_s)
            with np.errstate(divide="ignore", over="ignore"):
                np.log(dist, out=lam)
                np.subtract(np.take(logstep_flat, par, out=tmp, mode="clip"), lam, out=lam)
                np.minimum(lam, 0.0, out=lam)
                np.exp(lam, out=lam)
            dv *= lam[:, None]                                                    # (23): in place,
            dv += z_a                                                             # M (z_a + lam dv)
            if self.mix_modes:
                dv *= np.take(M_flat, AJ + i * r, out=tmp, mode="clip")[:, None]  # mu_{i|j}
            else:                                                                 # ablation: own parent only
                dv *= own[:, None]
            new += dv
        # x = m + L z per extra slot, run by run (A is non-decreasing: f is in C order): the same
        # einsum kernel as over a (K, n, n) gather of L, without that large temporary
        bounds = np.searchsorted(A, np.arange(R_ + 1))
        Lz = z_a                                                                  # (z_a is spent)
        for a in np.flatnonzero(bounds[1:] > bounds[:-1]):
            part = Lz[bounds[a]:bounds[a + 1]]
            np.einsum("ij,kj->ki", L[a], new[bounds[a]:bounds[a + 1]], out=part)
            part += m[a]                                                          # m + L z (addition commutes)
        _put_rows(out.reshape(-1, n), f, Lz)
        return out, n_disc

    def _resample(self, x, w, do, u_next, M_next, rng, k, cost):
        runs, r, N, n = x.shape
        replaced = np.zeros((runs, r), dtype=np.intp)
        sel = np.flatnonzero(do.any(axis=1))
        if sel.size == 0:
            return x, w, replaced
        rs = take_runs(rng, sel)
        uu = rs.random((sel.size, r))
        other = rs.integers(0, N, size=(sel.size, r, N))
        every = sel.size == runs
        ws = w if every else np.take(w, sel, axis=0)                             # (read only below)
        below = _systematic_below(ws, uu, N)
        counts = _counts_from_below(below)                                        # = systematic_counts(ws, uu, N)
        idx = _indices_from_below(below, N)
        dsel = do[sel]
        x = np.ascontiguousarray(x)
        if every:                          # the sets replaced in x itself
            x, n_disc = self.replacement(x, ws, u_next, M_next, counts, other, dsel, idx=idx, out=x)
        else:                              # the selected runs' sets (a copy in work memory), put back
            shape = (sel.size, r, N, n)
            xs = np.take(x, sel, axis=0) if self._work is None else np.take(
                x, sel, axis=0, out=self._work.get("x_sel", shape), mode="clip")
            xs, n_disc = self.replacement(xs, ws, u_next[sel], M_next[sel], counts, other, dsel, idx=idx, out=xs)
            _put_rows(x.reshape(runs, r * N * n), sel, xs.reshape(sel.size, r * N * n))
        cost["density"][sel] += r * N
        replaced[sel] = np.where(dsel, n_disc, 0)
        w = w.copy()
        w[do] = 1.0 / N
        return x, w, replaced

    def __repr__(self) -> str:
        return (f"IMMPFOR(r={self.system.r}, N={self.n_particles}, model_likelihood={self.model_likelihood!r}, "
                f"n_th={self.n_th}, d={self.d}, density={self.density!r}, replace={self.replace!r}, "
                f"mix_modes={self.mix_modes}, metric={self.metric!r})")


class IMMKalman(Filter):
    """Conventional IMM (Blom & Bar-Shalom 1988) with Kalman-family mode filters, batched over runs.

    Per step: mixing probabilities (eq 6) and mixed initial conditions
    x0_j = sum_i mu_{i|j} x_i, P0_j = sum_i mu_{i|j} [P_i + (x_i - x0_j)(x_i - x0_j)^T];
    mode-matched predict and update (each mode filter's own ``predict``/``update``);
    mode likelihoods Lambda_j = N(nu_j; 0, S_j) from the mode filter's innovation;
    u_j proportional to Lambda_j c_j; output x = sum_j u_j x_j with the spread-of-means
    covariance. Same order and convention as filterpy's ``IMMEstimator`` (``predict`` then
    ``update``, ``cbar = mu @ M``), against which it is tested.

    Parameters
    ----------
    system : JumpMarkovSystem
        The jump-Markov system (:class:`~pfrepro.models.jump_markov.JumpMarkovSystem`).
    mode_filters : list of GaussianFilter
        r :class:`~pfrepro.filters.GaussianFilter` instances (KF, EKF, UKF),
        filter j built on ``system.models[j]``; their ``predict(x, P, k)`` / ``update(x, P, y)``
        are used (their own m0/P0 are ignored: the IMM starts every mode at m0, P0).
    name : str
        A label, e.g. "IMM-EKF".
    on_divergence : {"warn", "drop", "raise"}
        A run whose estimates become non-finite: NaN from that step on and flagged, one
        warning (default), silent, or an error (as :class:`~pfrepro.filters.GaussianFilter`).

    Notes
    -----
    Diagnostics: ``mode_probs`` (runs, T, r), ``model_estimates`` (runs, T, r, n),
    ``log_model_likelihood`` (runs, T, r); ``diverged``, ``diverged_at``, ``n_diverged``
    (see ``on_divergence``).
    """

    needs_rng = False

    model_requirements = ()   # the mode filters check their own models

    def __init__(self, system, mode_filters, name: str = "IMM", m0=None, P0=None, on_divergence: str = "warn"):
        _init_on_system(self, system, m0, P0, ())
        self.on_divergence = check_divergence_policy(on_divergence)
        if isinstance(mode_filters, (str, bytes)) or not np.iterable(mode_filters) or hasattr(mode_filters, "filter"):
            raise TypeError(f"mode_filters must be a list of {system.r} Kalman-family filters, one per mode, "
                            f"got {mode_filters!r}")
        self.mode_filters = list(mode_filters)
        if len(self.mode_filters) != system.r:
            raise ValueError(f"mode_filters must hold one filter per mode ({system.r}), got {len(self.mode_filters)}")
        for j, f in enumerate(self.mode_filters):
            if not (hasattr(f, "predict") and hasattr(f, "update")):
                if hasattr(f, "simulate") and hasattr(f, "dim_x"):
                    raise TypeError(f"mode_filters[{j}] is a model ({type(f).__name__}), not a filter: give a "
                                    f"Kalman-family filter built on it, e.g. ExtendedKalmanFilter(system.models[{j}])")
                raise TypeError(f"mode filter {j} ({f!r}) has no predict/update: IMMKalman needs Kalman-family "
                                f"mode filters (KalmanFilter, ExtendedKalmanFilter, UnscentedKalmanFilter)")
            _check_mode_filter_model(f, system, j)
        self.name = str(name)

    @staticmethod
    def mix(x, P, M):
        """Mixed means (runs, r, n) and covariances (runs, r, n, n) from mode estimates and M = mu_{i|j}."""
        x0 = np.einsum("aij,ain->ajn", M, x)
        d = x[:, :, None, :] - x0[:, None, :, :]                                   # [a, i, j, n]
        P0 = np.einsum("aij,aimn->ajmn", M, P) + np.einsum("aij,aijm,aijn->ajmn", M, d, d)
        return x0, P0

    def filter(self, y, rng=None) -> FilterResult:
        y = self._prepare(y, rng)
        runs, T, _ = y.shape
        sysm = self.system
        r, n = sysm.r, sysm.dim_x
        x = np.broadcast_to(self.m0, (runs, r, n)).copy()
        P = np.broadcast_to(self.P0, (runs, r, n, n)).copy()
        mu = np.broadcast_to(sysm.initial_probs, (runs, r)).copy()
        xs = np.empty((runs, T, n))
        Ps = np.empty((runs, T, n, n))
        xj = np.empty((runs, T, r, n))
        probs = np.empty((runs, T, r))
        loglam = np.empty((runs, T, r))
        with np.errstate(all="ignore"):
            for k in range(1, T + 1):
                c, M = mixing_probabilities(mu, sysm.Pi)
                x0, P0 = self.mix(x, P, M)
                lam = np.empty((runs, r))
                for j, f in enumerate(self.mode_filters):
                    xp, Pp = f.predict(x0[:, j], P0[:, j], k)
                    x[:, j], P[:, j] = f.update(xp, Pp, y[:, k - 1])
                    lam[:, j] = gaussian_loglik(*f._last_innovation)
                mu = IMMParticleFilter.update_mode_probabilities(c, lam)
                est = np.einsum("ar,arn->an", mu, x)
                d = x - est[:, None, :]
                Ps[:, k - 1] = symmetrize(np.einsum("ar,armn->amn", mu, P) + np.einsum("ar,arm,arn->amn", mu, d, d))
                xs[:, k - 1], xj[:, k - 1], probs[:, k - 1], loglam[:, k - 1] = est, x, mu, lam
        diag = mark_diverged(self.name, self.on_divergence, np.isfinite(xs).all(axis=-1),
                             (xs, Ps, xj, probs, loglam))
        return FilterResult(xs, Ps, diagnostics={"mode_probs": probs, "model_estimates": xj,
                                                 "log_model_likelihood": loglam, **diag})

    def __repr__(self) -> str:
        return f"IMMKalman({self.name}, r={self.system.r})"
