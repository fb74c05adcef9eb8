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


# the radar tracking scenario of the IMM tests: CV, CT (3 deg/s) and CA modes, sticky Markov chain
TRACK_X0 = np.array([60000.0, -172.0, 0.0, 40000.0, 200.0, 0.0])
TRACK_MEAS = (100.0, 5.0, 0.01)
TRACK_P0 = np.diag(np.square([100.0, 10.0, 1.0, 100.0, 10.0, 1.0]))


def tracking_system():
    """Three radar-tracking modes (CV, CT, CA) on one 6-D state, switched by a sticky chain."""
    import math

    from pfrepro.models.jump_markov import JumpMarkovSystem
    from pfrepro.models.tracking import ca_model, ct_model, cv_model

    X0, MEAS, P0 = TRACK_X0, TRACK_MEAS, TRACK_P0
    ms = [cv_model(1.0, 1.0, MEAS, X0, P0=P0), ct_model(1.0, math.radians(3), 1.0, MEAS, X0, P0=P0),
          ca_model(1.0, 9.0, MEAS, X0, P0=P0)]
    return JumpMarkovSystem(ms, [[0.9, 0.05, 0.05], [0.05, 0.9, 0.05], [0.05, 0.05, 0.9]])


def three_claims_registry():
    """A claims registry of one reproduced, one not reproduced and one inconclusive claim (Li 2012's)."""
    from pfrepro.claims import ClaimsRegistry

    reg = ClaimsRegistry("ekf_pf_li2012")
    reg.add("cell", "EKF RMSE on model 1 is 13.2", published=13.2, reproduced=13.0, se=0.5)    # reproduced
    reg.add("ratio", "The EKF's RMSE is more than 7 times the PF's", diff=-3.0, diff_se=0.5)   # not reproduced
    reg.add("tie", "PF and EKF are close", diff=0.1, diff_se=0.5)                               # inconclusive
    return reg
