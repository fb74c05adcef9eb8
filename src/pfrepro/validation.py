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


def as_measurements(y, dim_y: int, name: str = "y") -> np.ndarray:
    """Return measurements as a finite ``(runs, T, dim_y)`` float array.

    Accepts ``(T,)`` (scalar measurements, one run), ``(T, dim_y)`` (one run) or
    ``(runs, T, dim_y)``; for ``dim_y == 1`` also ``(runs, T)``. Ambiguous 2-D
    input is read as ``(T, dim_y)`` when its last axis equals ``dim_y``.
    """
    arr = np.asarray(y, dtype=float)
    if arr.ndim == 1:
        if dim_y != 1:
            raise ValueError(f"{name} of shape {arr.shape} is 1-D but the model has dim_y = {dim_y}")
        arr = arr[None, :, None]
    elif arr.ndim == 2:
        if arr.shape[1] == dim_y:
            arr = arr[None]
        elif dim_y == 1:
            arr = arr[..., None]
        else:
            raise ValueError(f"{name} of shape {arr.shape} does not end in dim_y = {dim_y}")
    elif arr.ndim != 3 or arr.shape[2] != dim_y:
        raise ValueError(f"{name} must have shape (runs, T, {dim_y}), got {arr.shape}")
    if arr.shape[1] < 1:
        raise ValueError(f"{name} holds no time steps")
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise ValueError(f"{name} contains NaN or infinite measurements (first at run {bad[0]}, step {bad[1]})")
    return arr


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
    v = float(value)
    if not 0.0 <= v <= 1.0:
        raise ValueError(f"{name} must lie in [0, 1], got {value}")
    return v
