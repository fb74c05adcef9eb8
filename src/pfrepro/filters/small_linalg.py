"""Closed-form inverse and determinant of stacks of small matrices.

Filters that do linear algebra per particle (LEDH flows, local Kalman proposals) handle
10^4-10^6 matrices of size 1 x 1 or 2 x 2 per step, where LAPACK's per-matrix call overhead
dominates the arithmetic; these closed forms do the same work as vector operations. Each
matrix is treated on its own, so the result for one does not depend on the others
(batch-independent), and larger matrices fall back to ``numpy.linalg``.
"""
from __future__ import annotations

import numpy as np

__all__ = ["inv_small", "det_small"]


def inv_small(S):
    """Inverse of a stack ``(..., m, m)``: closed forms for m = 1 and 2, LAPACK otherwise."""
    m = S.shape[-1]
    if m == 1:
        return 1.0 / S
    if m == 2:
        a, b, c, d = S[..., 0, 0], S[..., 0, 1], S[..., 1, 0], S[..., 1, 1]
        det = a * d - b * c
        out = np.empty_like(S)
        out[..., 0, 0], out[..., 0, 1], out[..., 1, 0], out[..., 1, 1] = d / det, -b / det, -c / det, a / det
        return out
    return np.linalg.inv(S)


def det_small(J):
    """Determinant of a stack ``(..., n, n)``: closed forms for n = 1 and 2, LAPACK otherwise."""
    n = J.shape[-1]
    if n == 1:
        return J[..., 0, 0].copy()
    if n == 2:
        return J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
    return np.linalg.det(J)
