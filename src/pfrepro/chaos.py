"""Chaotic carrier sequences for the chaos-map-sampling particle filter (Ning et al. 2011).

Three carriers ``r`` for the map of Step 2.2 (see :mod:`pfrepro.filters.cmspf`):

* :func:`logistic_sequence` -- the logistic map, Ning et al. 2011 eq (1),
  ``x_{n+1} = u x_n (1 - x_n)``; values in (0, 1) (onto (0, 1) only for u = 4).
* :func:`chebyshev_sequence` -- the map of eq (6), ``x_{n+1} = 1 - 2 x_n^2``
  (printed as ``x(k+1) = 1 - 2 x^2(k+1)``, a misprint: the right side must use
  ``x(k)``); values in (-1, 1), zero mean.
* :func:`gaussian_sequence` -- the ``randn`` carrier of Table 3 (CMS1-PF).

Every chaotic generator iterates ``burn_in`` (the paper's T0, sec 3.3) times
before recording, and is vectorised over independent chains: the initial value
``x0`` may be an array, and the result has shape ``(n, *x0.shape)`` (iteration
index first). :class:`ChaosCarrier` packages a carrier for a filter: per Monte
Carlo run and map slot one chain, started from a seeded random initial value,
burnt in, and advanced one iteration per time step.

In double precision an orbit that comes within ~1e-8 of 1/2 (u = 4) or 0
(eq 6) rounds onto the end point of the interval and then sticks at a fixed
point (1 -> 0 -> 0, or 1 -> -1 -> -1): with 10^4 chains of 10^3 iterations this
happens in practice. Every iterate is therefore kept ``EDGE = 1e-12`` inside
the open interval (a change of at most 1e-12 to values that would otherwise
end the chaotic orbit); the end points are repelling, so the orbit leaves them
again. Initial values on (pre-)fixed points are rejected.
"""
from __future__ import annotations

import numpy as np

from .validation import check_positive_int
from .rng import RunStreams, check_rng

#: the clip ufunc itself: ``np.clip`` reaches it through three Python layers, about 1.5 us a call,
#: which the carrier's burn-in pays 1000 times (falls back to ``np.clip`` where numpy hides it)
_clip = getattr(getattr(getattr(np, "_core", None), "umath", None), "clip", np.clip)

__all__ = ["logistic_sequence", "chebyshev_sequence", "gaussian_sequence", "ChaosCarrier",
           "CARRIERS", "CARRIER_INITS", "DEFAULT_BURN_IN", "EDGE"]

#: default number of discarded iterations T0 (sec 3.3 leaves it open)
DEFAULT_BURN_IN = 1000

#: distance kept from the interval's end points (see the module docstring)
EDGE = 1e-12

#: carrier names accepted by :class:`ChaosCarrier`
CARRIERS = ("randn", "logistic", "chebyshev")

#: how a :class:`ChaosCarrier` starts and lays out its chains (the paper does not say) —
#: ``"chain"`` one chain per run and map slot, random start, advanced once per step;
#: ``"run"`` one chain per run, random start, its consecutive iterates filling the map slots
#: of step 1, then of step 2, ...; ``"shared"`` one sequence from a fixed start (``x0 = 0.65``
#: for eq 1, ``0.3`` for eq 6), generated once offline and used by every run, laid out as ``"run"``.
#: The ``randn`` carrier ignores it.
CARRIER_INITS = ("chain", "run", "shared")


def _check_burn_in(burn_in) -> int:
    if isinstance(burn_in, (bool, np.bool_)) or not isinstance(burn_in, (int, np.integer)) or burn_in < 0:
        raise ValueError(f"burn_in (T0) must be a non-negative integer, got {burn_in!r}")
    return int(burn_in)


def _check_initial(x0, lo, hi, bad, name):
    x = np.asarray(x0, dtype=float)
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name}: initial value contains NaN or inf")
    if np.any(x <= lo) or np.any(x >= hi):
        raise ValueError(f"{name}: initial values must lie in the open interval ({lo}, {hi}), got {x0!r}")
    for b in bad:
        if np.any(x == b):
            raise ValueError(f"{name}: initial value {b} is a (pre-)fixed point of the map; the orbit is not chaotic")
    return x.copy()


def logistic_sequence(n: int, x0=0.3, u: float = 4.0, burn_in: int = DEFAULT_BURN_IN) -> np.ndarray:
    """Logistic-map sequence, Ning et al. 2011 eq (1): ``x_{k+1} = u x_k (1 - x_k)``.

    Parameters
    ----------
    n : int
        Number of recorded values (after the burn-in).
    x0 : float or ndarray
        Initial value(s) in (0, 1); an array gives independent chains.
    u : float
        Control parameter; the paper's range is (3.56, 4.0]. The map is onto
        (0, 1) only for u = 4 (for u < 4 the values stay below u / 4), and the
        range contains periodic windows (e.g. near u = 3.83), so u = 4 is the default.
    burn_in : int
        Iterations T0 discarded before recording (sec 3.3).

    Returns
    -------
    ndarray
        ``(n, *shape(x0))`` values in (0, 1).
    """
    n = check_positive_int(n, "n")
    burn_in = _check_burn_in(burn_in)
    u = float(u)
    if not 3.56 < u <= 4.0:
        raise ValueError(f"u must lie in (3.56, 4.0] (eq 1), got {u}")
    x = _check_initial(x0, 0.0, 1.0, (0.5, 0.75) if u == 4.0 else (1.0 - 1.0 / u,), "logistic_sequence")
    lo, hi = EDGE, 1.0 - EDGE
    out = np.empty((n,) + x.shape)
    t = np.empty_like(x)
    # np.clip(t, lo, hi) is min(max(t, lo), hi), the same number as max(min(t, hi), lo) for
    # lo < hi and t not NaN, in one pass instead of two (numpy's minimum/maximum also check NaN)
    if u == 4.0:
        # iterate w = 4 x: w' = w (4 - w) = 4 x' exactly, because a factor 4 commutes with
        # rounding (no value here is subnormal or near overflow): 4 - 4x = 4 fl(1 - x), and
        # fl(4x fl(4(1 - x))) = 16 fl(x fl(1 - x)) = 4 fl(4 fl(x fl(1 - x))) -- the same
        # orbit as ``t = u (1 - x) x`` bit for bit, in three passes instead of five
        np.multiply(x, 4.0, out=x)
        for i in range(burn_in + n):
            np.subtract(4.0, x, out=t)
            t *= x
            _clip(t, 4.0 * lo, 4.0 * hi, out=x)
            if i >= burn_in:
                np.multiply(x, 0.25, out=out[i - burn_in, ...])   # a view also for a scalar x0
    else:
        for i in range(burn_in + n):
            np.subtract(1.0, x, out=t)
            t *= x
            t *= u
            _clip(t, lo, hi, out=x)
            if i >= burn_in:
                out[i - burn_in] = x
    if not (np.all(out > 0.0) and np.all(out < 1.0)):
        raise FloatingPointError("logistic orbit left (0, 1)")
    return out


def chebyshev_sequence(n: int, x0=0.3, burn_in: int = DEFAULT_BURN_IN) -> np.ndarray:
    """Sequence of the map of Ning et al. 2011 eq (6): ``x_{k+1} = 1 - 2 x_k^2`` on (-1, 1).

    (The second-order Chebyshev map; printed as ``x(k+1) = 1 - 2x^2(k+1)``,
    see the chapter's errata.) Its invariant density is the arcsine density
    ``1 / (pi sqrt(1 - x^2))`` with mean 0, so map particles fall on both sides
    of their centre. ``x0`` in (-1, 1), not 0, +-1/2 (pre-images of the fixed
    point -1 or the fixed point 1/2). Returns ``(n, *shape(x0))``.
    """
    n = check_positive_int(n, "n")
    burn_in = _check_burn_in(burn_in)
    x = _check_initial(x0, -1.0, 1.0, (0.0, 0.5, -0.5), "chebyshev_sequence")
    lo, hi = -1.0 + EDGE, 1.0 - EDGE
    out = np.empty((n,) + x.shape)
    t = np.empty_like(x)
    for i in range(burn_in + n):
        np.multiply(x, x, out=t)
        t *= -2.0
        t += 1.0
        _clip(t, lo, hi, out=x)     # = max(min(t, hi), lo) for lo < hi, t not NaN (one pass)
        if i >= burn_in:
            out[i - burn_in] = x
    if not (np.all(out > -1.0) and np.all(out < 1.0)):
        raise FloatingPointError("eq (6) orbit left (-1, 1)")
    return out


def gaussian_sequence(n: int, rng: np.random.Generator, shape=()) -> np.ndarray:
    """The ``randn`` carrier of Table 3 (CMS1-PF): iid N(0, 1), shape ``(n, *shape)``."""
    n = check_positive_int(n, "n")
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator, got {rng!r}")
    shape = tuple(int(s) for s in np.atleast_1d(shape)) if np.ndim(shape) or shape != () else ()
    return rng.standard_normal((n,) + shape)


class ChaosCarrier:
    """A carrier ``r`` for the CMS map (Ning et al. 2011, Step 2.2, sec 3.3).

    Parameters
    ----------
    kind : {"randn", "logistic", "chebyshev"}
        ``"randn"`` (CMS1), ``"logistic"`` (eq 1, CMS2) or ``"chebyshev"`` (eq 6, CMS3).
    u : float
        Logistic control parameter (eq 1).
    burn_in : int
        T0 of sec 3.3.
    init : str
        One of :data:`CARRIER_INITS` (default ``"chain"``, described in the notes).

    Notes
    -----
    :meth:`generate` returns ``(T, *shape)`` values: one chain per entry of
    ``shape`` (runs x map slots x state components), its initial value drawn
    from ``rng`` (uniform on the open interval, away from the excluded points),
    burnt in for T0 iterations, then advanced once per time step -- the
    sequence is computed "offline" before filtering, as sec 2.1 suggests.
    """

    def __init__(self, kind: str = "logistic", u: float = 4.0, burn_in: int = DEFAULT_BURN_IN,
                 init: str = "chain"):
        if init not in CARRIER_INITS:
            raise ValueError(f"unknown carrier initialisation {init!r}; choose from {CARRIER_INITS}")
        self.init = init
        if kind not in CARRIERS:
            raise ValueError(f"unknown carrier {kind!r}; choose from {CARRIERS}")
        self.kind = kind
        self.u = float(u)
        if kind == "logistic" and not 3.56 < self.u <= 4.0:
            raise ValueError(f"u must lie in (3.56, 4.0] (eq 1), got {u}")
        self.burn_in = _check_burn_in(burn_in)

    @property
    def support(self) -> tuple[float, float]:
        """The interval the carrier's values lie in, by ``kind``; (-inf, inf), (0, 1) or (-1, 1)."""
        return {"randn": (-np.inf, np.inf), "logistic": (0.0, 1.0), "chebyshev": (-1.0, 1.0)}[self.kind]

    def generate(self, T: int, shape, rng: np.random.Generator) -> np.ndarray:
        """``(T, *shape)`` carrier values; with per-run streams (:class:`~pfrepro.rng.RunStreams`)
        ``shape[0]`` is the number of runs and run i's chains come from run i's stream."""
        T = check_positive_int(T, "T")
        shape = tuple(int(s) for s in np.atleast_1d(shape))
        check_rng(rng)
        if self.kind == "randn":
            if isinstance(rng, RunStreams):  # runs axis first in the draw (pfrepro.rng rule 1)
                return np.ascontiguousarray(np.moveaxis(rng.standard_normal(shape[:1] + (T,) + shape[1:]), 1, 0))
            return rng.standard_normal((T,) + shape)
        if self.init != "chain":
            return self._generate_sequential(T, shape, rng)
        # initial values uniform on (0.01, 0.99) of the interval: away from its end points
        # (pre-fixed points such as 0.5 have probability zero under a continuous draw)
        v = rng.uniform(0.01, 0.99, shape)
        return self._sequence(T, v)

    def _sequence(self, n, v):
        """``n`` iterates (after burn-in) from start(s) ``v`` in (0, 1) of the interval."""
        if self.kind == "logistic":
            return logistic_sequence(n, v, self.u, self.burn_in)
        return chebyshev_sequence(n, 2.0 * v - 1.0, self.burn_in)

    def _generate_sequential(self, T, shape, rng):
        """``"run"`` / ``"shared"``: consecutive iterates of one chain fill the slots, step by step."""
        runs, slots = shape[0], int(np.prod(shape[1:], dtype=int))
        if self.init == "run":
            seq = self._sequence(T * slots, rng.uniform(0.01, 0.99, (runs,)))      # (T*slots, runs)
        else:
            seq = np.broadcast_to(self._sequence(T * slots, np.array([0.65])), (T * slots, runs))
        return np.ascontiguousarray(seq.reshape(T, slots, runs).transpose(0, 2, 1)).reshape((T,) + shape)

    def __repr__(self) -> str:
        extra = f", u={self.u}" if self.kind == "logistic" else ""
        extra += f", init={self.init!r}" if self.init != "chain" else ""
        return f"ChaosCarrier({self.kind!r}{extra}, burn_in={self.burn_in})"
