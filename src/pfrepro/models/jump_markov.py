"""Jump-Markov multiple-model systems: several mode models on one state vector.

A jump-Markov (hybrid) system (Zhou et al. 2017, eq 1; Blom & Bar-Shalom 1988) has a
discrete mode m_k in {0, ..., r-1} that follows a Markov chain and selects the
dynamics of the continuous state:

    P(m_k = j | m_{k-1} = i) = Pi[i, j]
    x_k = f_{m_k}(x_{k-1}, k) + w_k,   w_k ~ N(0, Q_{m_k})
    y_k = h(x_k) + v_k,                v_k ~ N(0, R)

**Transition-matrix convention (used everywhere in this package):** row = the mode
*from* (i, at k-1), column = the mode *to* (j, at k); every row sums to 1. The
predicted mode probabilities are therefore ``c = mu @ Pi`` (c_j = sum_i Pi[i, j] mu_i),
the same convention as filterpy's ``IMMEstimator`` code (``cbar = mu @ M``).

The modes share one measurement model: :class:`JumpMarkovSystem` takes ``h``,
its Jacobian, ``residual_y`` and the measurement noise from the first mode model
and checks that all modes agree on ``dim_x`` and ``dim_y``.

Simulation draws the mode sequence from the chain (one uniform per run and step,
runs axis first, so run i is the same in any batch) or follows a fixed mode
timeline (a *scheduled manoeuvre*, as tracking scenarios are usually written:
"constant velocity until 90 s, then a 3 deg/s turn for 20 s, ..."), see
:meth:`~pfrepro.models.JumpMarkovSystem.simulate`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..rng import check_rng
from ..validation import as_vector, check_positive_int
from .base import Simulation

__all__ = ["validate_transition_matrix", "stationary_distribution", "simulate_modes",
           "schedule_from_segments", "JumpMarkovSystem", "JumpMarkovSimulation"]

_ROW_TOL = 1e-9


def validate_transition_matrix(Pi, r: int | None = None, name: str = "transition_matrix") -> np.ndarray:
    """Return ``Pi`` as a float ``(r, r)`` row-stochastic matrix, else raise ``ValueError``.

    Convention: ``Pi[i, j] = P(m_k = j | m_{k-1} = i)`` (row = from, column = to);
    entries must be finite and in [0, 1] and every row must sum to 1 (within 1e-9).
    """
    P = np.asarray(Pi, dtype=float)
    if P.ndim != 2 or P.shape[0] != P.shape[1] or P.shape[0] < 1:
        raise ValueError(f"{name} must be a square (r, r) matrix, got shape {P.shape}")
    if r is not None and P.shape[0] != r:
        raise ValueError(f"{name} must be {r}x{r} (one row and column per mode), got {P.shape}")
    if not np.all(np.isfinite(P)):
        raise ValueError(f"{name} contains NaN or infinite entries")
    if np.any(P < 0) or np.any(P > 1):
        raise ValueError(f"{name} entries must lie in [0, 1] (probabilities), got min {P.min()}, max {P.max()}")
    rows = P.sum(axis=1)
    bad = np.flatnonzero(np.abs(rows - 1.0) > _ROW_TOL)
    if bad.size:
        raise ValueError(f"{name} rows must sum to 1 (row = from-mode i, column = to-mode j); "
                         f"row {bad[0]} sums to {rows[bad[0]]!r}")
    return P


def _probability_vector(p, r: int, name: str) -> np.ndarray:
    p = as_vector(p, name, r)
    if np.any(p < 0) or abs(p.sum() - 1.0) > _ROW_TOL:
        raise ValueError(f"{name} must be non-negative and sum to 1, got {p}")
    return p


def stationary_distribution(Pi) -> np.ndarray:
    """The stationary distribution pi = pi @ Pi of an (irreducible) chain, from the left eigenvector."""
    P = validate_transition_matrix(Pi)
    vals, vecs = np.linalg.eig(P.T)
    v = np.real(vecs[:, np.argmin(np.abs(vals - 1.0))])
    return v / v.sum()


def simulate_modes(Pi, initial_probs, T: int, runs: int, rng) -> np.ndarray:
    """Mode sequences ``(runs, T + 1)`` of the chain, ``modes[:, 0] ~ initial_probs``.

    One uniform per run and step (``rng.random((runs, 1))``, runs axis first), mapped
    through the cumulative row of the current mode: run i's modes do not depend on
    the batch it sits in when ``rng`` is a :class:`~pfrepro.rng.RunStreams`.
    """
    P = validate_transition_matrix(Pi)
    r = P.shape[0]
    p0 = _probability_vector(initial_probs, r, "initial_probs")
    T = check_positive_int(T, "T")
    runs = check_positive_int(runs, "runs")
    check_rng(rng)
    C = np.cumsum(P, axis=1)
    C[:, -1] = 1.0
    c0 = np.cumsum(p0)
    c0[-1] = 1.0
    modes = np.empty((runs, T + 1), dtype=np.intp)
    u = rng.random((runs, 1))[:, 0]
    modes[:, 0] = np.minimum(np.searchsorted(c0, u, side="right"), r - 1)
    for k in range(1, T + 1):
        u = rng.random((runs, 1))[:, 0]
        # first column whose cumulative probability exceeds u, for each run's own row
        modes[:, k] = np.minimum((C[modes[:, k - 1]] <= u[:, None]).sum(axis=1), r - 1)
    return modes


def schedule_from_segments(T: int, segments, default: int = 0) -> np.ndarray:
    """A mode timeline ``(T + 1,)`` from ``[(first_k, last_k, mode), ...]`` (inclusive steps).

    Steps not covered by a segment get ``default``. Entry k is the mode that
    drives the transition x_{k-1} -> x_k (entry 0 is the mode at the start).
    """
    T = check_positive_int(T, "T")
    sched = np.full(T + 1, int(default), dtype=np.intp)
    for first, last, mode in segments:
        if not (0 <= first <= last <= T):
            raise ValueError(f"segment ({first}, {last}) must satisfy 0 <= first <= last <= T = {T}")
        sched[first:last + 1] = int(mode)
    return sched


@dataclass(frozen=True)
class JumpMarkovSimulation(Simulation):
    """A :class:`~pfrepro.models.base.Simulation` plus the true modes ``(runs, T + 1)``."""

    modes: np.ndarray = None


class JumpMarkovSystem:
    """r mode models on one state vector, switched by a Markov chain (see module docstring).

    Parameters
    ----------
    models : sequence of StateSpaceModel
        One :class:`~pfrepro.models.StateSpaceModel` per mode, all with the
        same ``dim_x`` and ``dim_y``; the measurement model (``h``, ``jacobian_h``,
        ``residual_y``, measurement noise) and ``x0``, ``m0``, ``P0`` are taken from ``models[0]``.
    transition_matrix : ndarray
        ``(r, r)``, row = from, column = to, rows sum to 1.
    initial_probs : ndarray, optional
        ``(r,)`` initial mode probabilities (default uniform, as Zhou et al. sec 3).
    names : sequence of str, optional
        Mode names for tables and plots.
    schedule : ndarray, optional
        Fixed mode timeline ``(T + 1,)`` used by :meth:`simulate` when it is
        given none (so a scheduled-manoeuvre truth can be handed to a generic Monte Carlo runner).
    """

    def __init__(self, models, transition_matrix, initial_probs=None, names=None, schedule=None):
        self.models = list(models)
        if not self.models:
            raise ValueError("models must hold at least one mode model")
        self.r = len(self.models)
        m0 = self.models[0]
        for j, m in enumerate(self.models):
            if not all(hasattr(m, a) for a in ("dim_x", "dim_y", "sample_transition")):
                raise TypeError(f"models[{j}] must be a state-space model (pfrepro.models.StateSpaceModel), "
                                f"got {type(m).__name__}")
        for j, m in enumerate(self.models):
            if m.dim_x != m0.dim_x or m.dim_y != m0.dim_y:
                raise ValueError(f"mode model {j} has (dim_x, dim_y) = {(m.dim_x, m.dim_y)}, "
                                 f"mode 0 has {(m0.dim_x, m0.dim_y)}: modes must share one state and measurement")
        self.Pi = validate_transition_matrix(transition_matrix, self.r)
        self.initial_probs = (np.full(self.r, 1.0 / self.r) if initial_probs is None
                              else _probability_vector(initial_probs, self.r, "initial_probs"))
        self.names = [getattr(m, "name", f"mode {j}") for j, m in enumerate(self.models)] if names is None \
            else [str(n) for n in names]
        if len(self.names) != self.r:
            raise ValueError(f"names must have {self.r} entries, got {len(self.names)}")
        self.dim_x, self.dim_y = m0.dim_x, m0.dim_y
        # the system has one measurement model and one prior: mode 0's. A mode whose R, m0
        # or P0 differ would be silently ignored, so it is refused (issue 21)
        for j, m in enumerate(self.models[1:], start=1):
            for attr in ("R", "m0", "P0"):
                a, b = getattr(m0, attr, None), getattr(m, attr, None)
                if a is not None and b is not None and not np.array_equal(np.asarray(a), np.asarray(b)):
                    raise ValueError(f"models[{j}].{attr} differs from models[0].{attr}: a JumpMarkovSystem "
                                     f"shares one measurement model and one prior (mode 0's); give every "
                                     f"mode the same {attr}")
        self.measurement_noise = m0.measurement_noise
        self.x0, self.m0, self.P0 = m0.x0, m0.m0, m0.P0
        self.schedule = None if schedule is None else np.asarray(schedule)

    # the shared measurement model
    @property
    def R(self):
        """Measurement-noise covariance, shared by every mode (that of ``models[0]``)."""
        return self.models[0].R

    def h(self, x):
        """Measurement function h(x) (shared by every mode)."""
        return self.models[0].h(x)

    def jacobian_h(self, x):
        """Jacobian of h at ``x`` (shared by every mode)."""
        return self.models[0].jacobian_h(x)

    def residual_y(self, y, y_pred):
        """Measurement residual y - y_pred (angles wrapped where the model says so)."""
        return self.models[0].residual_y(y, y_pred)

    def log_likelihood(self, y, x):
        """log p(y | x) of the shared measurement model."""
        return self.models[0].log_likelihood(y, x)

    def simulate_modes(self, T: int, runs: int, rng) -> np.ndarray:
        """Mode sequences ``(runs, T + 1)`` drawn from the chain (see :func:`simulate_modes`)."""
        return simulate_modes(self.Pi, self.initial_probs, T, runs, rng)

    def simulate(self, T: int, runs: int = 1, rng=None, schedule=None) -> JumpMarkovSimulation:
        """Simulate modes, states and measurements of ``runs`` runs.

        ``schedule=None`` uses the system's own ``schedule`` if it has one, else draws the
        modes from the chain; a ``(T + 1,)`` integer array
        (see :func:`~pfrepro.models.jump_markov.schedule_from_segments`) fixes the same mode timeline for every run
        (a scheduled manoeuvre; the chain is then not used for the truth).
        Per step: one ``standard_normal((runs, dim_x))`` draw for the process noise (mapped
        through the active mode's square root of Q) and one ``(runs, dim_y)`` for the
        measurement noise, both runs-axis first.
        """
        T = check_positive_int(T, "T")
        runs = check_positive_int(runs, "runs")
        check_rng(rng)
        if schedule is None:
            schedule = self.schedule
        if schedule is None:
            modes = self.simulate_modes(T, runs, rng)
        else:
            sched = np.asarray(schedule)
            if sched.shape != (T + 1,) or not np.issubdtype(sched.dtype, np.integer):
                raise ValueError(f"schedule must be an integer array of shape (T + 1,) = {(T + 1,)}, got {sched.shape}")
            if sched.min() < 0 or sched.max() >= self.r:
                raise ValueError(f"schedule entries must be mode indices in [0, {self.r - 1}]")
            modes = np.broadcast_to(sched, (runs, T + 1)).copy()
        n = self.dim_x
        roots = [m.process_noise._chol for m in self.models]
        x = np.empty((runs, T + 1, n))
        y = np.empty((runs, T, self.dim_y))
        x[:, 0] = self.x0
        gaussian_v = not hasattr(self.measurement_noise, "components") and not np.any(self.measurement_noise.mean)
        if gaussian_v:
            root_v = np.linalg.cholesky(self.measurement_noise.cov)
        for k in range(1, T + 1):
            z = rng.standard_normal((runs, n))
            prev = x[:, k - 1]
            nxt = np.empty((runs, n))
            for j, m in enumerate(self.models):
                sel = modes[:, k] == j
                if sel.any():
                    # einsum, not a tall matmul: the result of row i must not depend on the batch size
                    nxt[sel] = m.f(prev[sel], k) + np.einsum("ij,rj->ri", roots[j], z[sel])
            x[:, k] = nxt
            if gaussian_v:
                v = np.einsum("ij,rj->ri", root_v, rng.standard_normal((runs, self.dim_y)))
            else:
                v = self.measurement_noise.sample(rng, runs)
            y[:, k - 1] = self.h(nxt) + v
        return JumpMarkovSimulation(x=x, y=y, modes=modes)

    def __repr__(self) -> str:
        return f"JumpMarkovSystem(r={self.r}, modes={self.names})"
