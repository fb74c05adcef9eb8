"""Input checks used at the public API boundary.

Every public constructor and ``filter`` method funnels its arguments through
these helpers so that a bad input fails loudly, with a message that names the
argument, instead of propagating as a silent NaN deep inside a filter.
"""
from __future__ import annotations

import numpy as np

__all__ = [
    "as_vector",
    "as_covariance",
    "as_measurements",
    "as_matrix",
    "as_finite_float",
    "MEASUREMENT_SHAPES",
    "check_positive_int",
    "check_probability",
]

#: Relative tolerance for symmetry checks of covariance matrices.
SYMMETRY_RTOL = 1e-9


def as_vector(value, name: str, dim: int | None = None) -> np.ndarray:
    """Return ``value`` as a finite 1-D float array, optionally of length ``dim``."""
    arr = np.atleast_1d(np.asarray(value, dtype=float))
    if arr.ndim != 1:
        raise ValueError(f"{name} must be a vector, got an array of shape {arr.shape}")
    if dim is not None and arr.shape[0] != dim:
        raise ValueError(f"{name} must have length {dim}, got {arr.shape[0]}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or infinite entries: {arr}")
    return arr


def as_covariance(value, name: str, dim: int | None = None, *, allow_singular: bool = False) -> np.ndarray:
    """Return ``value`` as a symmetric positive-(semi)definite ``(dim, dim)`` matrix.

    Scalars are accepted for ``dim == 1``. A covariance that is not symmetric
    (to relative tolerance ``SYMMETRY_RTOL``) or not positive definite raises
    ``ValueError``; ``allow_singular`` admits positive *semi*-definite matrices
    (e.g. a process noise that drives only part of the state).
    """
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        arr = arr.reshape(1, 1)
    if arr.ndim != 2 or arr.shape[0] != arr.shape[1]:
        raise ValueError(f"{name} must be a square matrix, got shape {arr.shape}")
    if dim is not None and arr.shape[0] != dim:
        raise ValueError(f"{name} must be {dim}x{dim}, got {arr.shape[0]}x{arr.shape[1]}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or infinite entries")
    scale = max(np.max(np.abs(arr)), np.finfo(float).tiny)
    if np.max(np.abs(arr - arr.T)) > SYMMETRY_RTOL * scale:
        raise ValueError(f"{name} is not symmetric:\n{arr}")
    eig = np.linalg.eigvalsh(0.5 * (arr + arr.T))
    floor = -1e-12 * scale if allow_singular else 0.0
    if eig.min() < floor or (not allow_singular and eig.min() <= 1e-14 * scale):
        kind = "positive semi-definite" if allow_singular else "positive definite"
        raise ValueError(f"{name} is not {kind} (smallest eigenvalue {eig.min():.3g})")
    return 0.5 * (arr + arr.T)


#: The accepted shapes of measurements, as every filter's docstring and error message says.
MEASUREMENT_SHAPES = ("(runs, T, dim_y) always; (T,) for one run of scalar measurements (dim_y == 1); "
                      "(T, dim_y) for one run only when dim_y > 1")


#: numpy dtype kinds that are real numbers (float, signed and unsigned integers)
_REAL_KINDS = frozenset("fiu")
_KIND_NAMES = {"b": "booleans", "c": "complex numbers", "M": "dates (datetime64)", "m": "time spans (timedelta64)",
               "U": "text", "S": "bytes", "O": "objects", "V": "raw records"}


def as_real_array(value, name: str) -> np.ndarray:
    """``value`` as a float array, refusing values that are not real numbers with a ``TypeError``.

    ``np.asarray(value, dtype=float)`` would read booleans as 0/1, drop the imaginary part of
    complex numbers (with only a ``ComplexWarning``), turn dates into nanoseconds and parse
    numeric strings; a measurement or setting is none of those."""
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError) as e:
        raise TypeError(f"{name} must be an array of real numbers, got {type(value).__name__} ({e})") from None
    kind = raw.dtype.kind
    if kind == "O":
        # lists of Python numbers mixed with None etc.: a float conversion decides, but a
        # bool or complex entry is refused as above
        flat = raw.ravel()
        bad = [v for v in flat[:10_000] if isinstance(v, (bool, np.bool_, complex, np.complexfloating, str, bytes))]
        if bad:
            raise TypeError(f"{name} must hold real numbers, got {type(bad[0]).__name__} {bad[0]!r}")
        try:
            return raw.astype(float)
        except (TypeError, ValueError):
            raise TypeError(f"{name} must hold real numbers, got entries such as {flat[0]!r}") from None
    if kind not in _REAL_KINDS:
        raise TypeError(f"{name} must hold real numbers, got {_KIND_NAMES.get(kind, raw.dtype.name)} "
                        f"(dtype {raw.dtype})")
    return raw.astype(float, copy=False)


def as_measurements(y, dim_y: int, name: str = "y") -> np.ndarray:
    """Return measurements as a finite ``(runs, T, dim_y)`` float array.

    Accepted shapes (nothing else, so no shape is read two ways):

    * ``(runs, T, dim_y)`` -- always (``runs >= 1``, ``T >= 1``);
    * ``(T,)`` -- one run of scalar measurements, only when ``dim_y == 1``;
    * ``(T, dim_y)`` -- one run, only when ``dim_y > 1``.

    A 2-D array with ``dim_y == 1`` is refused: ``(5, 1)`` could be five runs of
    one step or one run of five steps. Pass ``y[None]``/``y[..., None]`` to say
    which. Empty input (``runs == 0`` or ``T == 0``) and NaN/inf are refused, and so are
    values that are not real numbers (bool, complex, dates, text: ``TypeError``), which
    a float conversion would otherwise read as 0/1, drop the imaginary part of, or count
    in nanoseconds.
    """
    arr = as_real_array(y, name)
    hint = f"accepted shapes: {MEASUREMENT_SHAPES}"
    if arr.ndim == 1:
        if dim_y != 1:
            raise ValueError(f"{name} of shape {arr.shape} is 1-D but the model has dim_y = {dim_y}; {hint}")
        arr = arr[None, :, None]
    elif arr.ndim == 2:
        if dim_y == 1:
            raise ValueError(
                f"{name} of shape {arr.shape} is ambiguous for a model with dim_y = 1: it could be "
                f"(runs, T) or (T, dim_y); pass (runs, T, 1) (e.g. {name}[..., None] for runs x T, "
                f"{name}[None] for one run of T steps) or a 1-D (T,) array for one run")
        if arr.shape[1] != dim_y:
            raise ValueError(f"{name} of shape {arr.shape} does not end in dim_y = {dim_y}; {hint}")
        arr = arr[None]
    elif arr.ndim != 3 or arr.shape[2] != dim_y:
        raise ValueError(f"{name} must have shape (runs, T, {dim_y}), got {arr.shape}; {hint}")
    if arr.shape[0] < 1:
        raise ValueError(f"{name} holds no runs (shape {arr.shape}); at least one run is needed")
    if arr.shape[1] < 1:
        raise ValueError(f"{name} holds no time steps (shape {arr.shape})")
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise ValueError(f"{name} contains NaN or infinite measurements (first at run {bad[0]}, step {bad[1]})")
    return arr


def as_finite_float(value, name: str, *, positive: bool = False, nonnegative: bool = False) -> float:
    """Return ``value`` as a finite float (optionally > 0 or >= 0), else raise naming ``name``.

    Strings are refused (``float("0.5")`` would read one): a setting is a number, not text."""
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{name} must be a real number, got the string {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a real number, got {value!r}") from None
    if not np.isfinite(v):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if positive and not v > 0:
        raise ValueError(f"{name} must be positive, got {value!r}")
    if nonnegative and not v >= 0:
        raise ValueError(f"{name} must be >= 0, got {value!r}")
    return v


def as_matrix(value, name: str, shape: tuple | None = None) -> np.ndarray:
    """Return ``value`` as a finite 2-D float array (scalars read as 1x1), optionally of ``shape``.

    ``None`` in ``shape`` leaves that axis free.
    """
    arr = np.asarray(value, dtype=float)
    if arr.ndim < 2:
        arr = np.atleast_2d(arr)
    if arr.ndim != 2:
        raise ValueError(f"{name} must be a matrix, got an array of shape {arr.shape}")
    if shape is not None and any(s is not None and s != a for s, a in zip(shape, arr.shape)):
        want = ", ".join("n" if s is None else str(s) for s in shape)
        raise ValueError(f"{name} must have shape ({want}), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or infinite entries:\n{arr}")
    return arr


class TooLargeError(ValueError, MemoryError):
    """A request that would need more memory than the machine has, refused before allocating
    (a ``ValueError`` naming the argument, and a ``MemoryError``)."""


def physical_memory() -> int | None:
    """This machine's physical memory in bytes (None where the OS does not say)."""
    import os

    try:
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):  # pragma: no cover - not POSIX
        return None


def check_memory(nbytes: float, what: str, name: str = "runs", value=None) -> None:
    """Refuse, before allocating, a request of ``nbytes`` beyond the machine's physical memory.

    Raises :class:`TooLargeError` naming ``name`` (= ``value``) and the memory it would take,
    instead of numpy's bare ``MemoryError`` (or an endless loop building per-run streams)."""
    total = physical_memory()
    if total is not None and nbytes > total:
        shown = "" if value is None else f" = {value}"
        raise TooLargeError(
            f"{name}{shown} needs about {nbytes / 2**30:.3g} GiB for {what}, more than this machine's "
            f"{total / 2**30:.3g} GiB of memory; use fewer {name} (runs can be split over calls: run i's "
            f"numbers do not depend on how the runs are split)")


def check_positive_int(value, name: str) -> int:
    """Return ``value`` as an ``int`` >= 1, else raise ``ValueError``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        if not (isinstance(value, float) and value.is_integer()):
            raise TypeError(f"{name} must be a positive integer, got {value!r}")
    if int(value) < 1:
        raise ValueError(f"{name} must be >= 1, got {value}")
    return int(value)


def check_probability(value, name: str) -> float:
    """Return ``value`` as a float in [0, 1]."""
    v = as_finite_float(value, name)
    if not 0.0 <= v <= 1.0:
        raise ValueError(f"{name} must lie in [0, 1], got {value}")
    return v


def check_quantile_levels(q, name: str = "q") -> tuple:
    """Quantile levels: a number or a non-empty 1-D sequence of numbers in (0, 1) -> tuple of floats.

    (A level of 0 or 1 is an infinite quantile for an unbounded law, and 1.5 is none at all:
    both are refused rather than returned as NaN.)"""
    if isinstance(q, (str, bytes)):
        raise TypeError(f"{name} must be quantile levels in (0, 1), got the string {q!r}")
    try:
        arr = np.atleast_1d(np.asarray(q, dtype=float))
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be quantile levels in (0, 1), got {q!r}") from None
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"{name} must be a non-empty 1-D sequence of levels, got {q!r}")
    if not np.all((arr > 0) & (arr < 1)):
        raise ValueError(f"{name} must lie in (0, 1), got {q!r}")
    return tuple(float(v) for v in arr)
