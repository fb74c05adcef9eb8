"""Shared helpers for the pfrepro test suite (deterministic seeds everywhere)."""
from __future__ import annotations

import numpy as np
import pytest

from pfrepro.models import LinearGaussianModel


def random_spd(rng, n, floor=0.1):
    """A random symmetric positive-definite (n, n) matrix with eigenvalues >= floor."""
    A = rng.standard_normal((n, n))
    return A @ A.T / n + floor * np.eye(n)


def random_linear_model(seed, nx=3, ny=2):
    """A stable random linear-Gaussian model with dense F, H, Q, R, P0 (fixed seed)."""
    rng = np.random.default_rng(seed)
    F = rng.standard_normal((nx, nx))
    F *= 0.95 / np.max(np.abs(np.linalg.eigvals(F)))
    H = rng.standard_normal((ny, nx))
    x0 = rng.standard_normal(nx)
    m0 = x0 + 0.3 * rng.standard_normal(nx)
    return LinearGaussianModel(F, H, random_spd(rng, nx), random_spd(rng, ny), x0, m0=m0,
                               P0=random_spd(rng, nx, floor=0.5))


@pytest.fixture
def linear_model():
    return random_linear_model(12345)
