"""Bad inputs fail loudly at the API boundary with messages that name the problem."""
from __future__ import annotations

import numpy as np
import pytest

from pfrepro.filters import (BootstrapParticleFilter, ExtendedKalmanFilter, GridFilter, KalmanFilter,
                             UnscentedKalmanFilter)
from pfrepro.models import CWPA, UNGM, BearingsOnly, LinearGaussianModel, ModelContractError
from pfrepro.noise import GaussianMixtureNoise, GaussianNoise
from pfrepro.validation import (as_covariance, as_measurements, as_vector, check_positive_int,
                                check_probability)

NON_SYMMETRIC = np.array([[1.0, 0.5], [0.1, 1.0]])
INDEFINITE = np.array([[1.0, 2.0], [2.0, 1.0]])


def lg2():
    return LinearGaussianModel(np.eye(2) * 0.9, np.eye(2), np.eye(2), np.eye(2), [0.0, 0.0])


# ------------------------------------------------------------------ helpers ----------------------
def test_as_covariance():
    np.testing.assert_array_equal(as_covariance(2.0, "Q"), [[2.0]])
    with pytest.raises(ValueError, match="Q is not symmetric"):
        as_covariance(NON_SYMMETRIC, "Q")
    with pytest.raises(ValueError, match="R is not positive definite"):
        as_covariance(INDEFINITE, "R")
    with pytest.raises(ValueError, match="not positive definite"):
        as_covariance(np.zeros((2, 2)) + 1.0, "P0")  # singular
    np.testing.assert_array_equal(as_covariance(np.ones((2, 2)), "Q", allow_singular=True), np.ones((2, 2)))
    with pytest.raises(ValueError, match="positive semi-definite"):
        as_covariance(INDEFINITE, "Q", allow_singular=True)
    with pytest.raises(ValueError, match="square"):
        as_covariance(np.ones((2, 3)), "Q")
    with pytest.raises(ValueError, match="must be 3x3"):
        as_covariance(np.eye(2), "Q", 3)
    with pytest.raises(ValueError, match="NaN or infinite"):
        as_covariance([[1.0, np.nan], [np.nan, 1.0]], "Q")
    # round-off asymmetry is tolerated and removed
    A = np.array([[1.0, 0.3], [0.3 + 1e-12, 1.0]])
    out = as_covariance(A, "P")
    np.testing.assert_array_equal(out, out.T)


def test_as_vector_and_scalars():
    np.testing.assert_array_equal(as_vector(3.0, "x0"), [3.0])
    with pytest.raises(ValueError, match="x0 must have length 2"):
        as_vector([1.0, 2.0, 3.0], "x0", 2)
    with pytest.raises(ValueError, match="must be a vector"):
        as_vector(np.ones((2, 2)), "m0")
    with pytest.raises(ValueError, match="NaN or infinite"):
        as_vector([1.0, np.inf], "m0")
    assert check_positive_int(5, "N") == 5 and check_positive_int(np.int64(3), "N") == 3
    assert check_positive_int(4.0, "N") == 4
    with pytest.raises(ValueError, match="N must be >= 1"):
        check_positive_int(0, "N")
    with pytest.raises(TypeError, match="positive integer"):
        check_positive_int(2.5, "N")
    with pytest.raises(TypeError, match="positive integer"):
        check_positive_int(True, "N")
    with pytest.raises(TypeError, match="positive integer"):
        check_positive_int("10", "N")
    assert check_probability(0.5, "p") == 0.5
    with pytest.raises(ValueError, match=r"lie in \[0, 1\]"):
        check_probability(1.5, "p")


def test_as_measurements_shapes():
    assert as_measurements(np.zeros(5), 1).shape == (1, 5, 1)
    assert as_measurements(np.zeros((5, 2)), 2).shape == (1, 5, 2)
    with pytest.raises(ValueError, match="ambiguous"):   # (runs, T) or (T, 1)?
        as_measurements(np.zeros((3, 5)), 1)
    assert as_measurements(np.zeros((3, 5, 2)), 2).shape == (3, 5, 2)
    with pytest.raises(ValueError, match="1-D but the model has dim_y = 2"):
        as_measurements(np.zeros(5), 2)
    with pytest.raises(ValueError, match="does not end in dim_y = 2"):
        as_measurements(np.zeros((5, 3)), 2)
    with pytest.raises(ValueError, match=r"must have shape \(runs, T, 2\)"):
        as_measurements(np.zeros((3, 5, 3)), 2)
    with pytest.raises(ValueError, match="no time steps"):
        as_measurements(np.zeros((3, 0, 2)), 2)


# ------------------------------------------------------------------ models -----------------------
def test_model_constructor_errors():
    with pytest.raises(ValueError, match="Q is not symmetric"):
        LinearGaussianModel(np.eye(2), np.eye(2), NON_SYMMETRIC, np.eye(2), [0, 0])
    with pytest.raises(ValueError, match="R is not positive definite"):
        LinearGaussianModel(np.eye(2), np.eye(2), np.eye(2), INDEFINITE, [0, 0])
    with pytest.raises(ValueError, match="P0 is not positive definite"):
        LinearGaussianModel(np.eye(2), np.eye(2), np.eye(2), np.eye(2), [0, 0], P0=INDEFINITE)
    with pytest.raises(ValueError, match="F must be square"):
        LinearGaussianModel(np.ones((2, 3)), np.eye(2), np.eye(2), np.eye(2), [0, 0])
    with pytest.raises(ValueError, match=r"H must have shape \(n, 2\)"):
        LinearGaussianModel(np.eye(2), np.ones((1, 3)), np.eye(2), np.eye(1), [0, 0])
    with pytest.raises(ValueError, match="Q must be 2x2"):
        LinearGaussianModel(np.eye(2), np.eye(2), np.eye(3), np.eye(2), [0, 0])
    with pytest.raises(ValueError, match="x0 must have length 2"):
        LinearGaussianModel(np.eye(2), np.eye(2), np.eye(2), np.eye(2), [0, 0, 0])
    with pytest.raises(ValueError, match="truth_init"):
        UNGM(truth_init="random")
    with pytest.raises(ValueError, match="R is not positive definite"):
        UNGM(R=-1.0)
    with pytest.raises(ValueError, match="measurement noise has dimension 1"):
        BearingsOnly(measurement_noise=GaussianNoise(1.0))


def test_noise_constructor_errors():
    with pytest.raises(ValueError, match="sum to 1"):
        GaussianMixtureNoise([0.5, 0.6], [np.eye(2), np.eye(2)])
    with pytest.raises(ValueError, match="non-negative"):
        GaussianMixtureNoise([1.5, -0.5], [np.eye(2), np.eye(2)])
    with pytest.raises(ValueError, match="one covariance per mixture weight"):
        GaussianMixtureNoise([0.5, 0.5], [np.eye(2)])
    with pytest.raises(ValueError, match="same dimension"):
        GaussianMixtureNoise([0.5, 0.5], [np.eye(2), np.eye(3)])
    with pytest.raises(ValueError, match="not symmetric"):
        GaussianNoise(NON_SYMMETRIC)


def test_simulate_errors():
    m = UNGM.zhang2016()
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        m.simulate(10, runs=2)
    with pytest.raises(ValueError, match="T must be >= 1"):
        m.simulate(0, rng=np.random.default_rng(0))
    with pytest.raises(ValueError, match="runs must be >= 1"):
        m.simulate(5, runs=0, rng=np.random.default_rng(0))
    with pytest.raises(TypeError, match="runs must be a positive integer"):
        m.simulate(5, runs=2.5, rng=np.random.default_rng(0))


# ------------------------------------------------------------------ filters ----------------------
@pytest.mark.parametrize("make", [KalmanFilter, ExtendedKalmanFilter, UnscentedKalmanFilter,
                                  lambda m: BootstrapParticleFilter(m, 10)], ids=["KF", "EKF", "UKF", "PF"])
def test_filters_reject_bad_measurements(make):
    filt = make(lg2())
    rng = np.random.default_rng(0)
    y = np.zeros((2, 4, 2))
    y[1, 2, 0] = np.nan
    with pytest.raises(ValueError, match=r"NaN or infinite measurements \(first at run 1, step 2\)"):
        filt.filter(y, rng=rng)
    y[1, 2, 0] = np.inf
    with pytest.raises(ValueError, match="NaN or infinite"):
        filt.filter(y, rng=rng)
    with pytest.raises(ValueError, match=r"y must have shape \(runs, T, 2\), got \(2, 4, 3\)"):
        filt.filter(np.zeros((2, 4, 3)), rng=rng)
    with pytest.raises(ValueError, match="1-D but the model has dim_y = 2"):
        filt.filter(np.zeros(4), rng=rng)


@pytest.mark.parametrize("make", [KalmanFilter, ExtendedKalmanFilter, UnscentedKalmanFilter,
                                  lambda m, **kw: BootstrapParticleFilter(m, 10, **kw)],
                         ids=["KF", "EKF", "UKF", "PF"])
def test_filters_reject_bad_priors(make):
    with pytest.raises(ValueError, match="P0 is not symmetric"):
        make(lg2(), P0=NON_SYMMETRIC)
    with pytest.raises(ValueError, match="P0 is not positive definite"):
        make(lg2(), P0=INDEFINITE)
    with pytest.raises(ValueError, match="m0 must have length 2"):
        make(lg2(), m0=[0.0, 0.0, 0.0])


def test_particle_filter_settings():
    m = UNGM.zhang2016()
    with pytest.raises(ValueError, match="n_particles must be >= 1"):
        BootstrapParticleFilter(m, 0)
    with pytest.raises(ValueError, match="n_particles must be >= 1"):
        BootstrapParticleFilter(m, -5)
    with pytest.raises(TypeError, match="n_particles must be a positive integer"):
        BootstrapParticleFilter(m, 10.5)
    with pytest.raises(ValueError, match="unknown resampling scheme 'smart'"):
        BootstrapParticleFilter(m, 10, resampling="smart")
    with pytest.raises(ValueError, match=r"ess_threshold must lie in \[0, 1\]"):
        BootstrapParticleFilter(m, 10, ess_threshold=2.0)
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        BootstrapParticleFilter(m, 10).filter(np.zeros(5))
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        BootstrapParticleFilter(m, 10).filter(np.zeros(5), rng=42)


def test_kalman_filter_needs_linear_model():
    with pytest.raises(ModelContractError, match="KalmanFilter needs .*matrices F and H.*BearingsOnly has no"):
        KalmanFilter(BearingsOnly.zhang2016())


def test_ukf_rejects_bad_sigma_point_parameters():
    with pytest.raises(ValueError, match="n \\+ lambda"):
        UnscentedKalmanFilter(lg2(), alpha=1.0, kappa=-3.0)


def test_grid_filter_settings():
    with pytest.raises(ModelContractError, match=r"GridFilter needs .*scalar state \(dim_x == 1\).*dim_x = 2"):
        GridFilter(lg2())
    with pytest.raises(ModelContractError, match=r"LinearGaussianModel has dim_x = 2"):
        GridFilter(lg2())
    with pytest.raises(ModelContractError, match=r"CWPA has dim_x = 6"):
        GridFilter(CWPA.zhang2016())
    m = UNGM.zhang2016()
    with pytest.raises(ValueError, match="lo < hi"):
        GridFilter(m, bounds=(5.0, -5.0))
    with pytest.raises(ValueError, match="too coarse"):
        GridFilter(m, bounds=(-60, 60), n_grid=101)
    with pytest.raises(ValueError, match="n_grid must be >= 3"):
        GridFilter(m, bounds=(-0.1, 0.1), n_grid=2)
    with pytest.raises(ValueError, match="n_grid must be >= 1"):
        GridFilter(m, n_grid=0)
    with pytest.raises(ValueError, match="NaN or infinite"):
        GridFilter(m).filter(np.array([1.0, np.nan]))
