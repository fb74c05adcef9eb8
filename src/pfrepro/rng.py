"""Per-run random streams: run i's numbers do not depend on the batch it sits in.

A Monte Carlo experiment runs all its runs in one vectorised call, so every draw
is an array whose first axis is the run. With one ``numpy.random.Generator`` for
the whole batch, run 0's draws change when the batch holds 1 run or 100, and an
experiment cannot be grown from 100 to 200 runs, or split across processes,
without changing its numbers.

:class:`RunStreams` holds one generator per run and answers the same draw calls
as a ``Generator`` (``standard_normal``, ``random``, ``uniform``, ``normal``,
``beta``, ``gamma``, ``exponential``, ``poisson``, ``choice``, ``integers``,
``permuted``), filling slice ``[i]`` of the result from run i's own generator. Filters and models therefore stay written
against the ``Generator`` interface; the only rule they follow is

    **every draw has the runs axis first** (``size=(runs, ...)``), and a draw
    made for a subset of runs uses ``take_runs(rng, sel)``.

Run i's generator is seeded by ``SeedSequence(entropy, spawn_key=(i,))``, which
depends on i and on the experiment's entropy only (not on how many runs there
are, nor on which process draws them), so growing an experiment keeps its first
runs bit-identical and any split of runs over an executor gives the same numbers.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

__all__ = ["RunStreams", "take_runs", "run_stream", "check_rng", "is_rng"]


class RunStreams:
    """One ``numpy.random.Generator`` per Monte Carlo run (see module docstring).

    Parameters
    ----------
    generators : sequence of numpy.random.Generator
        One generator per run, in run order.

    Notes
    -----
    Use :meth:`from_entropy` to build the streams of runs ``start .. start + runs - 1``
    of an experiment.
    """

    def __init__(self, generators: Sequence[np.random.Generator]):
        gens = list(generators)
        if not gens:
            raise ValueError("RunStreams needs at least one generator (one per run)")
        for g in gens:
            if not isinstance(g, np.random.Generator):
                raise TypeError(f"RunStreams holds numpy.random.Generator objects, got {g!r}")
        self._gens = gens
        # bound methods, looked up once: the per-run loops below are the whole cost of
        # per-run streams at small N (one call per run and draw)
        self._standard_normal = [g.standard_normal for g in gens]
        self._random = [g.random for g in gens]

    @classmethod
    def from_entropy(cls, entropy, runs: int, start: int = 0) -> "RunStreams":
        """Streams of runs ``start, ..., start + runs - 1`` of the experiment keyed by ``entropy``.

        ``entropy`` is an int or a sequence of ints (e.g. ``[seed, 1, crc32(name)]``).
        Run i gets ``default_rng(SeedSequence(entropy, spawn_key=(i,)))``.
        """
        from .validation import check_memory, check_positive_int

        runs = check_positive_int(runs, "runs")
        # a generator and its seed sequence take about 2.4 kB (measured): refuse a count of runs
        # that cannot fit before building the list (10**10 runs used to run until memory ran out)
        check_memory(2400.0 * runs, "one random generator per run", "runs", runs)
        if isinstance(start, (bool, np.bool_)) or not isinstance(start, (int, np.integer)):
            raise TypeError(f"start must be an integer >= 0, got {start!r}")
        ent = np.atleast_1d(np.asarray(entropy, dtype=object))
        if not all(isinstance(e, (int, np.integer)) and not isinstance(e, (bool, np.bool_)) and e >= 0
                   for e in ent.ravel()):
            raise ValueError(f"entropy must be an int >= 0 or a sequence of them, got {entropy!r}")
        start = int(start)
        if runs < 1 or start < 0:
            raise ValueError(f"need runs >= 1 and start >= 0, got runs={runs}, start={start}")
        return cls([np.random.default_rng(np.random.SeedSequence(entropy, spawn_key=(i,)))
                    for i in range(start, start + runs)])

    # -- container protocol ------------------------------------------------------
    def __len__(self) -> int:
        return len(self._gens)

    def __iter__(self):
        return iter(self._gens)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return RunStreams(self._gens[i])
        return self._gens[i]

    def subset(self, sel) -> "RunStreams":
        """Streams of the runs selected by ``sel`` (boolean mask or integer indices)."""
        sel = np.asarray(sel)
        n = len(self._gens)
        if sel.dtype == bool:
            if sel.shape != (n,):
                raise ValueError(f"RunStreams.subset: a boolean sel must have shape ({n},) (one flag per run), "
                                 f"got shape {sel.shape}")
            idx = np.flatnonzero(sel)
        else:
            if sel.size and not np.issubdtype(sel.dtype, np.integer):
                raise TypeError(f"RunStreams.subset: sel must be a boolean mask or integer run indices, "
                                f"got {sel.dtype} values")
            idx = sel.ravel()
            if idx.size and (idx.min() < 0 or idx.max() >= n):
                raise ValueError(f"RunStreams.subset: sel holds run indices outside 0..{n - 1}: {idx.tolist()}")
        return RunStreams([self._gens[int(i)] for i in idx])

    def __repr__(self) -> str:
        return f"RunStreams(runs={len(self)})"

    # -- draws -------------------------------------------------------------------
    def _size(self, size, what: str) -> tuple:
        if type(size) is tuple and size and size[0] == len(self._gens) \
                and all(type(s) is int and s >= 0 for s in size):
            return size                       # the hot path of every filter step: already valid
        if size is None:
            raise ValueError(f"RunStreams.{what} needs size=(runs, ...) with the runs axis first")
        raw = np.atleast_1d(np.asarray(size, dtype=object))
        if raw.ndim != 1 or not all(isinstance(s, (int, np.integer)) and not isinstance(s, (bool, np.bool_))
                                    and s >= 0 for s in raw):
            raise ValueError(f"RunStreams.{what}: size must be a tuple of integers >= 0, got {size!r}")
        size = tuple(int(s) for s in raw)
        if not size or size[0] != len(self._gens):
            raise ValueError(
                f"RunStreams.{what}: size {size} must start with the number of runs ({len(self._gens)}); "
                "every draw of a batched filter has the runs axis first")
        return size

    def _per_run(self, method: str, size, *params, dtype=float):
        """Draw ``size`` by calling ``Generator.method(*params_i, size=size[1:])`` for each run i.

        Array parameters broadcast against ``size``; run i gets slice ``[i]``.
        """
        size = self._size(size, method)
        try:
            params = [p if np.ndim(p) == 0 else np.broadcast_to(p, size) for p in params]
        except ValueError:
            raise ValueError(f"RunStreams.{method}: parameters of shapes {[np.shape(p) for p in params]} do not "
                             f"broadcast against size {size}") from None
        out = np.empty(size, dtype=dtype)
        try:
            for i, g in enumerate(self._gens):
                out[i] = getattr(g, method)(*[p if np.ndim(p) == 0 else p[i] for p in params], size=size[1:])
        except (ValueError, TypeError) as e:
            # numpy's message names the parameter but not the call ("scale < 0"): say which draw
            # and what it was given (the first run's values), as at any API boundary
            names = self._PARAM_NAMES.get(method, ())
            given = ", ".join(f"{n}={_short(p)}" for n, p in zip(names, params))
            raise type(e)(f"RunStreams.{method}({given}): invalid parameter: {e} "
                          f"(numpy.random.Generator.{method})") from None
        return out

    #: the parameter names of the per-run draws, for error messages
    _PARAM_NAMES = {"normal": ("loc", "scale"), "uniform": ("low", "high"), "beta": ("a", "b"),
                    "gamma": ("shape", "scale"), "exponential": ("scale",), "poisson": ("lam",)}

    def standard_normal(self, size=None, dtype=np.float64):
        """``Generator.standard_normal`` per run, with the runs axis first.

        Parameters
        ----------
        size : tuple of int
            ``(runs, ...)``; its first entry must equal ``len(self)`` (``ValueError`` otherwise).
        dtype : {float64, float32}, optional
            Output dtype (an integer type).

        Returns
        -------
        ndarray
            Shape ``size``; slice ``[i]`` is drawn from run i's Generator alone, so it does
            not depend on the other runs.
        """
        return self._fill(self._standard_normal, self._size(size, "standard_normal"), dtype)

    def random(self, size=None, dtype=np.float64):
        """``Generator.random`` per run, with the runs axis first.

        Parameters
        ----------
        size : tuple of int
            ``(runs, ...)``; its first entry must equal ``len(self)`` (``ValueError`` otherwise).
        dtype : {float64, float32}, optional
            Output dtype; draws are uniform on [0, 1).

        Returns
        -------
        ndarray
            Shape ``size``; slice ``[i]`` is drawn from run i's Generator alone, so it does
            not depend on the other runs.
        """
        return self._fill(self._random, self._size(size, "random"), dtype)

    @staticmethod
    def _fill(methods, size, dtype):
        """One array ``size``; run i's slice filled in place (``out=``) by ``methods[i]``."""
        out = np.empty(size, dtype=dtype)
        rows = out.reshape(size[0], -1)       # a view: each row is run i's contiguous slice
        if np.dtype(dtype) == np.float64:
            for draw, row in zip(methods, rows):
                draw(out=row)
        else:
            for draw, row in zip(methods, rows):
                draw(dtype=dtype, out=row)
        return out

    def normal(self, loc=0.0, scale=1.0, size=None):
        """``Generator.normal`` per run, with the runs axis first.

        Parameters
        ----------
        loc, scale : float or array_like
            Mean and standard deviation; arrays broadcast against ``size``, run i uses slice ``[i]``.
        size : tuple of int
            ``(runs, ...)``; its first entry must equal ``len(self)`` (``ValueError`` otherwise).

        Returns
        -------
        ndarray
            Shape ``size``; slice ``[i]`` is drawn from run i's Generator alone, so it does
            not depend on the other runs.
        """
        return self._per_run("normal", size, loc, scale)

    def uniform(self, low=0.0, high=1.0, size=None):
        """``Generator.uniform`` per run, with the runs axis first.

        Parameters
        ----------
        low, high : float or array_like
            Interval [low, high); arrays broadcast against ``size``, run i uses slice ``[i]``.
        size : tuple of int
            ``(runs, ...)``; its first entry must equal ``len(self)`` (``ValueError`` otherwise).

        Returns
        -------
        ndarray
            Shape ``size``; slice ``[i]`` is drawn from run i's Generator alone, so it does
            not depend on the other runs.
        """
        return self._per_run("uniform", size, low, high)

    def beta(self, a, b, size=None):
        """``Generator.beta`` per run, with the runs axis first.

        Parameters
        ----------
        a, b : float or array_like
            Positive shape parameters; arrays broadcast against ``size``, run i uses slice ``[i]``.
        size : tuple of int
            ``(runs, ...)``; its first entry must equal ``len(self)`` (``ValueError`` otherwise).

        Returns
        -------
        ndarray
            Shape ``size``; slice ``[i]`` is drawn from run i's Generator alone, so it does
            not depend on the other runs.
        """
        return self._per_run("beta", size, a, b)

    def gamma(self, shape, scale=1.0, size=None):
        """``Generator.gamma`` per run, with the runs axis first.

        Parameters
        ----------
        shape, scale : float or array_like
            Shape k > 0 and scale θ > 0; arrays broadcast against ``size``, run i uses slice ``[i]``.
        size : tuple of int
            ``(runs, ...)``; its first entry must equal ``len(self)`` (``ValueError`` otherwise).

        Returns
        -------
        ndarray
            Shape ``size``; slice ``[i]`` is drawn from run i's Generator alone, so it does
            not depend on the other runs.
        """
        return self._per_run("gamma", size, shape, scale)

    def exponential(self, scale=1.0, size=None):
        """``Generator.exponential`` per run, with the runs axis first.

        Parameters
        ----------
        scale : float or array_like
            Mean 1/λ > 0; an array broadcasts against ``size``, run i uses slice ``[i]``.
        size : tuple of int
            ``(runs, ...)``; its first entry must equal ``len(self)`` (``ValueError`` otherwise).

        Returns
        -------
        ndarray
            Shape ``size``; slice ``[i]`` is drawn from run i's Generator alone, so it does
            not depend on the other runs.
        """
        return self._per_run("exponential", size, scale)

    def poisson(self, lam=1.0, size=None):
        """``Generator.poisson`` per run, with the runs axis first (count models).

        Parameters
        ----------
        lam : float or array_like
            Rate λ >= 0; an array broadcasts against ``size``, run i uses slice ``[i]``.
        size : tuple of int
            ``(runs, ...)``; its first entry must equal ``len(self)`` (``ValueError`` otherwise).

        Returns
        -------
        ndarray of int64
            Shape ``size``; slice ``[i]`` is drawn from run i's Generator alone, so it does
            not depend on the other runs.
        """
        return self._per_run("poisson", size, lam, dtype=np.int64)

    def integers(self, low, high=None, size=None, dtype=np.int64):
        """``Generator.integers`` per run, with the runs axis first.

        Parameters
        ----------
        low, high : int
            Draws from [low, high); ``high=None`` means [0, low). Shared by every run.
        size : tuple of int
            ``(runs, ...)``; its first entry must equal ``len(self)`` (``ValueError`` otherwise).
        dtype : numpy dtype, optional
            Output dtype (an integer type).

        Returns
        -------
        ndarray
            Shape ``size``; slice ``[i]`` is drawn from run i's Generator alone, so it does
            not depend on the other runs.
        """
        size = self._size(size, "integers")
        lo, hi = (0, low) if high is None else (low, high)
        if np.any(np.asarray(lo) >= np.asarray(hi)):
            raise ValueError(f"RunStreams.integers draws from [low, high) and needs low < high, "
                             f"got low={low!r}, high={high!r}")
        out = np.empty(size, dtype=dtype)
        for i, g in enumerate(self._gens):
            out[i] = g.integers(low, high, size=size[1:], dtype=dtype)
        return out

    def choice(self, a, size=None, replace=True, p=None):
        """``Generator.choice`` per run; ``a`` and ``p`` are shared by every run.

        ``p`` (if given) must be one finite, non-negative probability per element of ``a``
        summing to 1 (``ValueError`` naming ``p`` otherwise).
        """
        size = self._size(size, "choice")
        if p is not None:
            try:
                pa = np.asarray(p, dtype=float)
            except (TypeError, ValueError):
                raise TypeError(f"RunStreams.choice: p must be an array of probabilities, got {p!r}") from None
            n_a = int(a) if np.ndim(a) == 0 else len(a)
            if pa.shape != (n_a,) or not np.all(np.isfinite(pa)) or np.any(pa < 0) \
                    or abs(pa.sum() - 1.0) > np.sqrt(np.finfo(float).eps):
                raise ValueError(f"RunStreams.choice: p must hold {n_a} finite probabilities >= 0 "
                                 f"summing to 1 (one per element of a), got {p!r}")
        first = self._gens[0].choice(a, size=size[1:], replace=replace, p=p)
        out = np.empty(size, dtype=np.asarray(first).dtype)
        out[0] = first
        for i, g in enumerate(self._gens[1:], start=1):
            out[i] = g.choice(a, size=size[1:], replace=replace, p=p)
        return out

    def permuted(self, x, axis=None):
        """Permute each run's slice ``x[i]`` independently along ``axis`` (>= 1)."""
        x = np.asarray(x)
        if axis is None or axis == 0 or x.shape[0] != len(self._gens):
            raise ValueError("RunStreams.permuted needs x with the runs axis first and axis >= 1")
        out = np.empty_like(x)
        for i, g in enumerate(self._gens):
            out[i] = g.permuted(x[i], axis=axis - 1 if axis > 0 else axis)
        return out


def _short(p) -> str:
    """A parameter for an error message: a scalar as is, an array by shape and range."""
    if np.ndim(p) == 0:
        return repr(p.item() if hasattr(p, "item") else p)
    a = np.asarray(p)
    try:
        return f"array{a.shape} in [{np.nanmin(a):.4g}, {np.nanmax(a):.4g}]"
    except (TypeError, ValueError):
        return f"array{a.shape} of {a.dtype}"


def is_rng(rng) -> bool:
    """True for a ``numpy.random.Generator`` or a :class:`RunStreams`."""
    return isinstance(rng, (np.random.Generator, RunStreams))


def check_rng(rng, name: str = "rng"):
    """Return ``rng`` if it is a ``Generator`` or ``RunStreams``, else raise ``TypeError``.

    Integers, ``None`` and legacy ``RandomState`` objects are refused on purpose:
    an implicit seed or the global state would make results irreproducible.
    """
    if not is_rng(rng):
        raise TypeError(
            f"{name} must be a numpy.random.Generator (e.g. numpy.random.default_rng(seed)) "
            f"or a pfrepro.rng.RunStreams, got {type(rng).__name__}: {rng!r}")
    return rng


def take_runs(rng, sel):
    """The random source for a subset ``sel`` of the runs (boolean mask or indices).

    A ``Generator`` is shared by all runs and is returned as is; a ``RunStreams``
    is narrowed to the selected runs' streams, so a run draws from its own stream
    whether or not the other runs draw at this step.
    """
    return rng.subset(sel) if isinstance(rng, RunStreams) else rng


def run_stream(rng, i: int) -> np.random.Generator:
    """The generator that run ``i`` draws from (the shared one for a plain ``Generator``)."""
    return rng[i] if isinstance(rng, RunStreams) else rng
