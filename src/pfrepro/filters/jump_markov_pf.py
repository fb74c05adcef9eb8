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
transitions are drawn as in ``JumpMarkovSystem.simulate``: one
standard-normal draw per particle, mapped through the active mode's square root of Q, so
every draw has the runs axis first and run i is the same in any batch.
"""
from __future__ import annotations

import numpy as np

from ..validation import check_positive_int, check_probability
from .resampling import check_scheme
from .smc_steps import ParticleLoop

__all__ = ["JumpMarkovParticleFilter"]


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
        self._roots = np.stack([m.process_noise._chol for m in system.models])   # (r, n, n)
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
        z = rng.standard_normal((runs, N, n))
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
                # einsum on the mode's rows: row i's arithmetic does not depend on the batch
                np.add(m.f(xo[a:b], k), np.einsum("ij,pj->pi", self._roots[j], zo[a:b]), out=moved[a:b])
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
