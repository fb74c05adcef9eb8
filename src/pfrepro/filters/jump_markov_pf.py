"""Jump-Markov particle filter: the mode sampled per particle (Boers & Driessen 2005 style).

IMMPF and IMMPFOR (Zhou 2017) keep one particle cloud per mode and mix them through the
IMM interaction step. The direct alternative treats the mode as part of the state: each
particle carries (x, r), its mode jumps with the Markov chain and its state moves with
that mode's dynamics, and the bootstrap weights do the rest (McGinnity & Irwin 2000;
Boers & Driessen 2005, the "multiple model PF"):

    r_k^i ~ Pi[r_{k-1}^i, :]                  (mode jump)
    x_k^i ~ p_{r_k^i}(x_k | x_{k-1}^i)         (that mode's transition)
    w_k^i ∝ w_{k-1}^i p(y_k | x_k^i)           (the shared measurement model)

Mode probabilities are the weight sums per mode; the estimate is the weighted mean. The
transitions are drawn as the mode models draw them: q standard normals per particle, mapped
through the active mode's square-root factor of Q (:func:`noise_roots`: the model's low-rank
factor B with Q = B B^T where it gives one, as the manoeuvring-target models do with q = 2 of
a 6-D state; else the Cholesky or symmetric root, q = n). Every draw has the runs axis first,
so run i is the same in any batch.
"""
from __future__ import annotations

import numpy as np

from ..validation import check_positive_int, check_probability
from .resampling import check_scheme
from .smc_steps import ParticleLoop

__all__ = ["JumpMarkovParticleFilter", "noise_roots"]


def noise_roots(models) -> np.ndarray:
    """Each mode's square-root factor of its process noise, ``(r, n, q)``: Q_j = R_j R_j^T.

    A model with a low-rank factor (``noise_factor``, B of shape (n, q_j) with Q = B B^T, as
    :mod:`pfrepro.models.tracking` builds them) gives B, which its own ``sample_transition``
    uses: q_j normals per state instead of n. Any other gives its noise's Cholesky factor (or
    symmetric root, for a singular Q). Factors narrower than the widest are padded with zero
    columns, so one draw of q = max q_j normals per particle serves every mode.
    """
    roots = []
    for m in models:
        B = getattr(m, "noise_factor", None)
        roots.append(np.asarray(B, float) if B is not None else m.process_noise._chol)
    n = roots[0].shape[0]
    if any(R.ndim != 2 or R.shape[0] != n for R in roots):
        raise ValueError(f"every mode's noise factor must have {n} rows, got {[R.shape for R in roots]}")
    q = max(R.shape[1] for R in roots)
    out = np.zeros((len(roots), n, q))
    for j, R in enumerate(roots):
        out[j, :, :R.shape[1]] = R
    return out


def _take_rows(a, rows):
    """``a.reshape(-1, n)[rows]`` (shape ``rows.shape + (n,)``) for a float array ``a`` (..., n): each
    row moved as one opaque record (``np.take`` on a void view, a byte copy per row, several times
    faster than a float row gather). The result is allocated as a float array and filled in place:
    a void array of numpy's own would be zero-filled fresh memory (calloc), a page fault per 4 kB
    on every call. ``rows`` must be valid row indices (they are not checked)."""
    n = a.shape[-1]
    a2 = np.ascontiguousarray(a).reshape(-1, n)
    rec = np.dtype((np.void, n * a2.itemsize))
    out = np.empty(np.shape(rows) + (n,), dtype=a2.dtype)
    # mode="clip": no bounds check, so numpy takes straight into ``out`` (mode="raise" buffers it)
    np.take(a2.view(rec)[:, 0], rows, out=out.reshape(-1, n).view(rec)[:, 0].reshape(np.shape(rows)), mode="clip")
    return out


def noise_rows(z, root):
    """``z @ root.T`` for the rows ``z`` (P, q) of one mode's particles, P >= 1, as a BLAS GEMM
    (several times faster than the equivalent einsum). A GEMM rounds a row the same way whatever
    the number of rows, except a lone row, which BLAS sends to its matrix-vector kernel: a lone
    row is multiplied as the first of two, so a particle's numbers never depend on how many
    particles of the batch share its mode."""
    if z.shape[0] == 1:
        return (np.concatenate([z, z]) @ root.T)[:1]
    return z @ root.T


class JumpMarkovParticleFilter(ParticleLoop):
    """Bootstrap particle filter on the joint (state, mode) of a jump-Markov system.

    Parameters
    ----------
    system : JumpMarkovSystem
        Mode models with additive Gaussian process noise (``f`` and ``Q``) and a shared
        measurement model.
    n_particles : int
        N >= 1 (in total, not per mode).
    resampling : str
        ``"systematic"`` (default), ``"stratified"``, ``"multinomial"`` or ``"residual"``.
    ess_threshold : float or None
        None (resample every step) or a fraction in [0, 1].
    m0, P0 : array_like, optional
        Override the system's initial distribution N(m0, P0).

    Notes
    -----
    Diagnostics: ``mode_probs`` (runs, T, r), ``ess`` (runs, T), ``resampled`` (runs, T),
    ``log_evidence`` (runs,), ``collapsed``, ``n_collapsed``.
    """

    name = "JMPF"
    model_requirements = ()

    def __init__(self, system, n_particles: int, resampling: str = "systematic",
                 ess_threshold: float | None = None, m0=None, P0=None):
        if not hasattr(system, "models") or not hasattr(system, "Pi"):
            raise TypeError(f"JumpMarkovParticleFilter needs a JumpMarkovSystem, got {type(system).__name__}")
        super().__init__(system, m0, P0)
        self.system = system
        self.n_particles = check_positive_int(n_particles, "n_particles")
        self.resampling = check_scheme(resampling)
        self.ess_threshold = None if ess_threshold is None else check_probability(ess_threshold, "ess_threshold")
        self._roots = noise_roots(system.models)                                   # (r, n, q)
        self._cum_Pi = np.cumsum(system.Pi, axis=1)
        self._cum_init = np.cumsum(system.initial_probs)

    @staticmethod
    def _draw_modes(cum, u):
        """Inverse-CDF mode draws: the first j with u < cum[..., j] (cum (..., r), u (...))."""
        return np.minimum((u[..., None] >= cum).sum(axis=-1), cum.shape[-1] - 1)

    def _start(self, y, rng, runs, N):
        x = self.sample_prior(rng, (runs, N))
        mode = self._draw_modes(self._cum_init, rng.random((runs, N)))
        return x, {"mode": mode, "carried": (mode,),
                   "diag": {"mode_probs": np.empty((runs, y.shape[1], self.system.r))}}

    def _move(self, k, x, logw, yk, rng, state):
        # self.model (the system): a cost count's proxy sees the mode models' and the likelihood's calls
        sysm = self.model
        runs, N, n = x.shape
        r = len(sysm.models)
        # the mode draw of _draw_modes (the first j with u < cum[prev, j], capped at r - 1) without
        # gathering the (runs, N, r) cumulative rows: one comparison per column, the same integers
        prev = state["mode"]
        u = rng.random((runs, N))
        mode = np.zeros(prev.shape, dtype=np.intp)
        for j in range(r):
            mode += u >= np.take(self._cum_Pi[:, j], prev)
        np.minimum(mode, r - 1, out=mode)
        z = rng.standard_normal((runs, N, self._roots.shape[-1]))
        # the particles grouped by mode once (a stable sort keeps each mode's particles in their
        # order: the rows each mode's f sees are those a boolean mask would select, so the numbers
        # are the same), each mode's block moved, the blocks put back by the inverse permutation.
        # The gathers move whole rows as opaque records (np.take on a void view: a byte copy per
        # row, several times faster than a float fancy index); the arithmetic is unchanged
        flat = mode.ravel().astype(np.int8 if r < 128 else np.int64)
        order = np.argsort(flat, kind="stable")          # a radix sort for 8-bit keys
        bounds = np.searchsorted(flat[order], np.arange(r + 1))
        xo, zo = _take_rows(x, order), _take_rows(z, order)
        moved = np.empty_like(xo)
        for j, m in enumerate(sysm.models):
            a, b = bounds[j], bounds[j + 1]
            if b > a:
                np.add(m.f(xo[a:b], k), noise_rows(zo[a:b], self._roots[j]), out=moved[a:b])
        inv = np.empty_like(order)
        inv[order] = np.arange(order.size)
        nxt = _take_rows(moved, inv).reshape(x.shape)
        state["mode"], state["carried"] = mode, (mode,)
        return nxt, sysm.log_likelihood(yk, nxt)

    def _after_weight(self, k, w, x, x_hat, state):
        mode = state["mode"]
        out = state["diag"]["mode_probs"][:, k - 1]
        for j in range(self.system.r):
            out[:, j] = np.where(mode == j, w, 0.0).sum(axis=1)

    def __repr__(self) -> str:
        return (f"JumpMarkovParticleFilter(N={self.n_particles}, r={self.system.r}, "
                f"resampling={self.resampling!r}, ess_threshold={self.ess_threshold})")
