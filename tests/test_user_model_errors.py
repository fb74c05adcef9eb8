"""A user's model and data errors are caught where they happen (issue 34, items 7 and 8):
NaN log-likelihoods, trajectories that leave the numbers, measurements that are not real
numbers, and a few settings that used to end in raw numpy errors."""
from __future__ import annotations

import numpy as np
import pytest

from pfrepro.filters import BootstrapParticleFilter, ExtendedKalmanFilter, GridFilter
from pfrepro.models import UNGM, StateSpaceModel
from pfrepro.montecarlo import filter_streams


class Counts(StateSpaceModel):
    """A count model written with a slip: the intensity is x instead of exp(x), so the
    log-likelihood y log(x) - x is NaN for every particle below zero."""

    additive_measurement_noise = False

    def __init__(self):
        super().__init__(1, 1, 0.1, 1.0, [0.0], [0.0], 1.0)

    def f(self, x, k):
        return 0.9 * x

    def log_likelihood(self, y, x):
        y = np.asarray(y, float).reshape(y.shape[:1] + (1,) * (x.ndim - 2))
        lam = x[..., 0]
        with np.errstate(invalid="ignore", divide="ignore"):
            return y * np.log(lam) - lam

    def sample_measurement(self, x, rng):
        return rng.poisson(np.exp(x)).astype(float)


def test_nan_log_likelihood_is_an_error_naming_the_model_and_runs():
    """Before: the NaN particles silently got zero weight and the PF returned numbers."""
    m = Counts()
    y = m.simulate(10, 2, np.random.default_rng(0)).y
    with pytest.raises(ValueError, match=r"Counts\.log_likelihood returned NaN for \d+ finite state\(s\) in runs "
                                         r"\[0, 1\] \(first at index \(0, \d+\), x = \[-"):
        BootstrapParticleFilter(m, 100).filter(y, filter_streams(0, "PF", 2))
    with pytest.raises(ValueError, match=r"Counts\.log_likelihood returned NaN"):
        GridFilter(m, bounds=(-5, 5), n_grid=401).filter(y)


def test_nan_from_h_through_the_default_likelihood_is_caught_too():
    class SqrtH(UNGM):
        def h(self, x):
            with np.errstate(invalid="ignore"):
                return np.sqrt(x)                 # NaN for x < 0

    m = SqrtH()
    y = np.abs(UNGM().simulate(5, 2, np.random.default_rng(0)).y)
    with pytest.raises(ValueError, match=r"SqrtH\.log_likelihood returned NaN"):
        BootstrapParticleFilter(m, 200).filter(y, filter_streams(0, "PF", 2))


def test_a_nan_only_at_a_non_finite_state_is_not_the_models_fault():
    from pfrepro.models.base import check_log_likelihood

    m = UNGM()
    x = np.array([[[np.nan], [1.0]]])
    check_log_likelihood(m, np.zeros((1, 1)), x, np.array([[np.nan, -3.0]]))          # no error
    with pytest.raises(ValueError, match="UNGM.log_likelihood returned NaN for 1 finite state"):
        check_log_likelihood(m, np.zeros((1, 1)), x, np.array([[-1.0, np.nan]]))


def test_simulate_leaving_the_numbers_names_the_step():
    """Before: NaN/inf trajectories were returned with only numpy's overflow warning."""
    class Boom(StateSpaceModel):
        def __init__(self):
            super().__init__(1, 1, 0.1, 1.0, [1.0], [0.0], 1.0)

        def f(self, x, k):
            with np.errstate(over="ignore"):
                return np.exp(np.exp(x * k))

        def h(self, x):
            return x

    with pytest.raises(FloatingPointError, match=r"Boom\.simulate: the state x_k became non-finite at step k = 2 "
                                                 r"in 3 of 3 runs \(first run 0: x_1 = \["):
        Boom().simulate(10, 3, np.random.default_rng(0))


@pytest.mark.parametrize("y, kind", [
    (np.array(["2020-01-01", "2020-01-02", "2020-01-03"], dtype="datetime64[D]"), "dates"),
    (np.array([True, False, True]), "booleans"),
    (np.array([1.0, 2.0, 3.0]) + 0.5j, "complex numbers"),
    (np.array(["1.0", "2.0", "3.0"]), "text"),
])
def test_measurements_that_are_not_real_numbers_are_refused(y, kind):
    """Before: dates were filtered as nanosecond counts, booleans as 0/1, complex numbers
    without their imaginary part (one ComplexWarning), numeric text parsed."""
    with pytest.raises(TypeError, match=f"y must hold real numbers, got {kind}"):
        ExtendedKalmanFilter(UNGM()).filter(y)
    with pytest.raises(TypeError, match=f"y must hold real numbers, got {kind}"):
        BootstrapParticleFilter(UNGM(), 10).filter(y, np.random.default_rng(0))


def test_real_measurements_of_any_real_dtype_give_the_same_numbers():
    y = UNGM().simulate(5, 1, np.random.default_rng(0)).y
    ref = ExtendedKalmanFilter(UNGM()).filter(y).x
    np.testing.assert_array_equal(ExtendedKalmanFilter(UNGM()).filter(y.tolist()).x, ref)
    yi = np.round(y).astype(np.int32)
    np.testing.assert_array_equal(ExtendedKalmanFilter(UNGM()).filter(yi).x,
                                  ExtendedKalmanFilter(UNGM()).filter(yi.astype(float)).x)


# -- item 8: clear errors at the boundary instead of raw numpy ones ----------------------------------
def test_ten_billion_runs_are_refused_before_allocating():
    """Before: simulate raised numpy's MemoryError, run_monte_carlo built per-run streams until the
    memory ran out (an empty MemoryError). Now a TooLargeError (ValueError and MemoryError) naming runs."""
    import time

    from pfrepro.montecarlo import run_monte_carlo, truth_streams
    from pfrepro.validation import TooLargeError

    t0 = time.process_time()
    for call in (lambda: UNGM().simulate(10, 10**10, np.random.default_rng(0)),
                 lambda: run_monte_carlo(UNGM(), {"EKF": ExtendedKalmanFilter(UNGM())}, 10, 10**10, 1),
                 lambda: truth_streams(1, 10**10)):
        with pytest.raises(TooLargeError, match=r"runs = 10000000000 needs about .* GiB .* more than this machine's"):
            call()
    assert time.process_time() - t0 < 5
    assert issubclass(TooLargeError, ValueError) and issubclass(TooLargeError, MemoryError)


def test_raw_numpy_errors_became_clear_ones():
    from pfrepro.export import filter_result_frame
    from pfrepro.filters.imm import IMMKalman, IMMPFOR
    from pfrepro.models import JumpMarkovSystem
    from pfrepro.results import FilterResult
    from pfrepro.rng import RunStreams

    s = RunStreams.from_entropy(1, 2)
    with pytest.raises(ValueError, match=r"RunStreams\.normal\(loc=0, scale=-1\): invalid parameter: scale < 0"):
        s.normal(0, -1, size=(2, 3))
    with pytest.raises(ValueError, match=r"RunStreams\.poisson\(lam=-2\.0\): invalid parameter"):
        s.poisson(-2.0, size=(2, 3))
    with pytest.raises(ValueError, match=r"RunStreams\.normal: parameters of shapes \[\(5,\), \(\)\] do not broadcast"):
        s.normal(np.zeros(5), 1.0, size=(2, 3))
    with pytest.raises(TypeError, match="name must be the filter's name .* got 5"):
        filter_streams(1, 5, 2)
    ms = [UNGM(alpha=0.5), UNGM(alpha=0.4)]
    sysm = JumpMarkovSystem(ms, [[0.9, 0.1], [0.1, 0.9]])
    with pytest.raises(TypeError, match="step coefficient d must be a positive number, got 'x'"):
        IMMPFOR(sysm, 10, d="x")
    with pytest.raises(TypeError, match=r"mode_filters\[0\] is a model \(UNGM\), not a filter: .*ExtendedKalmanFilter"):
        IMMKalman(sysm, ms)
    with pytest.raises(TypeError, match="mode_filters must be a list of 2 Kalman-family filters"):
        IMMKalman(sysm, ExtendedKalmanFilter(ms[0]))
    with pytest.raises(TypeError, match="IMMKalman needs a pfrepro.models.JumpMarkovSystem, got UNGM"):
        IMMKalman(ms[0], [ExtendedKalmanFilter(m) for m in ms])
    x = np.zeros((2, 3, 1))
    for P in (np.ones((2, 3, 1)), np.ones((2, 3, 2, 2)), np.array([["a"]])):
        with pytest.raises(ValueError, match=r"result\.P must be covariances of shape \(runs, T, dim_x, dim_x\) = "
                                             r"\(2, 3, 1, 1\)"):
            filter_result_frame(FilterResult(x, P))
    assert len(filter_result_frame(FilterResult(x, np.ones((2, 3, 1, 1))))) == 6
