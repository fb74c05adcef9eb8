"""Closed-form inverse and determinant of stacks of small matrices.

Filters that do linear algebra per particle (LEDH flows, local Kalman proposals) handle
10^4-10^6 matrices of size 1 x 1 or 2 x 2 per step, where LAPACK's per-matrix call overhead
dominates the arithmetic; these closed forms do the same work as vector operations. Each
matrix is treated on its own, so the result for one does not depend on the others
(batch-independent), and larger matrices fall back to ``numpy.linalg``.
"""
from __future__ import annotations

import numpy as np

__all__ = ["inv_small", "det_small", "cholesky_small", "CHOLESKY_SMALL_MAX", "mm_components", "inv_components",
           "cholesky_components"]

#: the largest n :func:`cholesky_small` factors entry by entry (n (n + 1) / 2 vector operations)
CHOLESKY_SMALL_MAX = 6


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


def _stack_contiguous(a):
    return a if a.ndim < 3 or a.strides[-1] in (0, a.itemsize) else np.ascontiguousarray(a)


def mm_components(A, B):
    """Matrix product of stacks stored small axes first: ``A`` (p, q, ...) times ``B`` (q, r, ...)
    -> (p, r, ...), the sum over q written out in order (q vector operations over the stack).

    Each stacked matrix's entries are sums of the same terms in the same order whatever the
    stack's size; a constant matrix broadcasts as (p, q, 1, ...). An operand whose stack axis is
    not contiguous (a moved-axis view) is copied once first: every product would inherit its
    strides otherwise."""
    A, B = _stack_contiguous(A), _stack_contiguous(B)
    out = A[:, 0, None] * B[None, 0]
    for k in range(1, A.shape[1]):
        out += A[:, k, None] * B[None, k]
    return out


def inv_components(S):
    """:func:`inv_small` for a stack stored small axes first, ``S`` (m, m, ...), m = 1 or 2."""
    m = S.shape[0]
    if m == 1:
        return 1.0 / S
    if m == 2:
        a, b, c, d = S[0, 0], S[0, 1], S[1, 0], S[1, 1]
        det = a * d - b * c
        return np.array([[d / det, -b / det], [-c / det, a / det]])
    return np.moveaxis(np.linalg.inv(np.moveaxis(S, (0, 1), (-2, -1))), (-2, -1), (0, 1))


def cholesky_components(a):
    """Lower Cholesky factors of a stack stored small axes first, ``a`` (n, n, ...): the
    Cholesky–Banachiewicz recursion, one vector operation over the stack per term.
    Raises ``numpy.linalg.LinAlgError`` where a pivot is not positive (or NaN)."""
    n = a.shape[0]
    L = np.zeros_like(a)
    for j in range(n):
        s = a[j, j].copy()
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if not np.all(s > 0):
            raise np.linalg.LinAlgError("Matrix is not positive definite")
        d = np.sqrt(s)
        L[j, j] = d
        for i in range(j + 1, n):
            t = a[i, j].copy()
            for k in range(j):
                t -= L[i, k] * L[j, k]
            L[i, j] = t / d
    return L


def cholesky_small(A):
    """Lower Cholesky factors of a stack ``(..., n, n)`` of symmetric positive-definite matrices.

    For n <= :data:`CHOLESKY_SMALL_MAX` the Cholesky–Banachiewicz recursion runs entry by entry,
    each entry one vector operation over the whole stack (LAPACK's batched call pays a fixed
    cost per matrix, which dominates for 4 x 4 matrices); larger n falls back to
    ``numpy.linalg.cholesky``. Raises ``numpy.linalg.LinAlgError`` if a matrix of the stack is
    not positive definite (a pivot <= 0 or NaN), as ``numpy.linalg.cholesky`` does.
    """
    A = np.asarray(A, dtype=float)
    if A.ndim < 2 or A.shape[-2] != A.shape[-1]:
        raise ValueError(f"A must be a stack of square matrices (..., n, n), got shape {A.shape}")
    if A.shape[-1] > CHOLESKY_SMALL_MAX:
        return np.linalg.cholesky(A)
    L = cholesky_components(np.ascontiguousarray(np.moveaxis(A, (-2, -1), (0, 1))))
    return np.moveaxis(L, (0, 1), (-2, -1))
