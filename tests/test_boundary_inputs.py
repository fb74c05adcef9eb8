"""Issue 21, inputs checked at the boundary: each example of the issue is a clear error naming
the argument, and a declarative table of public callables x bad values driven by hypothesis.

To cover a new public function, add a row to ``TABLE``: (label, call(value), parameter name,
a strategy of bad values). Each generated value must raise ValueError/TypeError (or KeyError
for a lookup) whose message names the parameter -- never a numpy/scipy internal error, never
a silent NaN or a wrong answer."""
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pfrepro.filters import BootstrapParticleFilter, GaussianParticleFlowFilter
from pfrepro.filters.particle import normalize_log_weights
from pfrepro.models import UNGM
from pfrepro.montecarlo import run_monte_carlo
from pfrepro.rng import RunStreams
from pfrepro.validation import as_finite_float, check_positive_int, check_probability

UNG = UNGM.zhang2016()
PF = BootstrapParticleFilter(UNG, 10)


def _mc(**kw):
    args = dict(model=UNG, filters={"PF": PF}, T=3, runs=2, seed=1)
    args.update(kw)
    return run_monte_carlo(args.pop("model"), args.pop("filters"), args.pop("T"), args.pop("runs"),
                           args.pop("seed"), progress=False, **args)


# -- the examples ---------------------------------------------------------------------
@pytest.mark.parametrize("seed", [1.5, -1, None, "abc", True])
def test_run_monte_carlo_seed(seed):
    with pytest.raises((TypeError, ValueError), match="seed"):
        _mc(seed=seed)


@pytest.mark.parametrize("filters, match", [
    ([PF], "filters must be a dict"), ({"PF": "pf"}, r"filters\['PF'\]"), ({3: PF}, "name must be a string"),
])
def test_run_monte_carlo_filters(filters, match):
    with pytest.raises((TypeError, ValueError), match=match):
        _mc(filters=filters)


def test_run_monte_carlo_model_and_executor():
    with pytest.raises(TypeError, match="model"):
        _mc(model=None)
    for ex in ("abc", 3):
        with pytest.raises(TypeError, match="executor"):
            _mc(executor=ex)
    pool = ProcessPoolExecutor(1)
    pool.shutdown()
    with pytest.raises(ValueError, match="shut down"):
        _mc(executor=pool)


class _Unpicklable(UNGM):
    pass


def test_unpicklable_model_with_a_process_pool_names_the_attribute():
    m = _Unpicklable()
    m.callback = lambda x: x                      # a lambda cannot be pickled
    with ProcessPoolExecutor(1) as pool, pytest.raises(TypeError, match="model.*attribute callback"):
        _mc(model=m, filters={"PF": BootstrapParticleFilter(m, 10)}, executor=pool)


def test_monte_carlo_result_unknown_filter_name_lists_the_names():
    res = _mc()
    with pytest.raises(KeyError, match=r"no filter named 'nope'.*\['PF'\]"):
        res.mse("nope")
    assert res.n_diverged() == {"PF": 0}
    # a run counts as lost once any of its estimates is non-finite; it counts once
    res.results["PF"].x[1, 2, 0] = np.nan
    assert res.n_diverged() == {"PF": 1}
    res.results["PF"].x[1, :] = np.inf
    res.results["PF"].x[0, 0] = np.nan
    assert res.n_diverged() == {"PF": 2}


def test_run_streams_checks():
    with pytest.raises(TypeError, match="runs"):
        RunStreams.from_entropy(0, 2.5)
    with pytest.raises(ValueError, match="entropy"):
        RunStreams.from_entropy(-1, 2)
    rs = RunStreams.from_entropy(0, 3)
    with pytest.raises(ValueError, match="size"):
        rs.standard_normal((3.7, 2))
    with pytest.raises(ValueError, match="size"):
        rs.standard_normal((3, -2))


def test_run_streams_integers_choice_subset_checks():
    """Issue 21: integers(5, 2), bad choice probabilities and out-of-range subsets crashed inside
    numpy or a list (IndexError), or were accepted (a mask of the wrong length, a float index,
    -1 read as the last run)."""
    rs = RunStreams.from_entropy(0, 3)
    for lo, hi in ((5, 2), (2, 2), (0, None)):
        with pytest.raises(ValueError, match="low < high"):
            rs.integers(lo, hi, size=(3, 2))
    for p in ([0.5, 0.6, 0.1], [1.5, -0.5, 0.0], [0.5, 0.5], [np.nan, 0.5, 0.5], [[0.5, 0.5, 0.0]]):
        with pytest.raises(ValueError, match="p must hold 3"):
            rs.choice(3, size=(3, 2), p=p)
    with pytest.raises(TypeError, match="p must be"):
        rs.choice(3, size=(3, 2), p="abc")
    for sel in ([3], [-1], [0, 5]):
        with pytest.raises(ValueError, match=r"outside 0\.\.2"):
            rs.subset(sel)
    with pytest.raises(ValueError, match=r"shape \(3,\)"):
        rs.subset(np.array([True, False]))
    with pytest.raises(TypeError, match="integer run indices"):
        rs.subset([0.5])
    # the valid calls: same draws as each run's own Generator
    ref = RunStreams.from_entropy(0, 3)
    np.testing.assert_array_equal(rs.integers(2, 5, size=(3, 4)),
                                  np.stack([g.integers(2, 5, size=4) for g in ref]))
    np.testing.assert_array_equal(rs.choice(3, size=(3, 4), p=[0.2, 0.3, 0.5]),
                                  np.stack([g.choice(3, size=4, p=[0.2, 0.3, 0.5]) for g in ref]))
    assert list(rs.subset([2, 0])) == [rs[2], rs[0]]
    assert list(rs.subset(np.array([False, True, True]))) == [rs[1], rs[2]]


def test_normalize_log_weights_checks():
    with pytest.raises(ValueError, match=r"\+inf"):
        normalize_log_weights(np.array([[0.0, np.inf]]))
    with pytest.raises(ValueError, match="2-D"):
        normalize_log_weights(np.zeros(3))
    w, _, coll = normalize_log_weights([[0.0, np.log(3.0)]])         # a list is read as an array
    np.testing.assert_allclose(w, [[0.25, 0.75]])
    assert not coll.any()


@pytest.mark.parametrize("value", ["0.5", "1", b"2"])
def test_strings_are_not_numbers(value):
    """(Any numeric setting read through validation.as_finite_float; the table below covers more.)"""
    with pytest.raises(TypeError, match="q0"):
        from pfrepro.experiments.dpf_hou2008 import model_51
        from pfrepro.filters.dual_ekf import DualExtendedKalmanFilter
        DualExtendedKalmanFilter(model_51(), 0.5, 0.1, q0=value)


# -- the systematic pass: a declarative table ------------------------------------------------
nonfinite = st.sampled_from([float("nan"), float("inf"), -float("inf")])
not_a_number = st.one_of(st.text(max_size=4), st.none(), st.lists(st.integers(), max_size=2),
                         st.dictionaries(st.text(max_size=2), st.integers(), max_size=1))
bad_count = st.one_of(st.integers(max_value=0), st.floats(allow_nan=True).filter(lambda v: not float(v).is_integer()
                                                                                 if np.isfinite(v) else True),
                      not_a_number, st.booleans())
bad_seed = st.one_of(st.integers(max_value=-1), st.floats().filter(lambda v: not (np.isfinite(v) and v.is_integer())),
                     not_a_number, st.booleans())

bad_levels = st.one_of(st.lists(st.floats(min_value=1.0), min_size=1, max_size=3),
                       st.lists(st.floats(max_value=0.0), min_size=1, max_size=3), st.just([]), st.text(max_size=3),
                       st.lists(nonfinite, min_size=1, max_size=2))


def _lw(**kw):
    from pfrepro.filters.liu_west import LiuWestFilter
    from pfrepro.models.ungm_theta import UNGMTheta

    return LiuWestFilter(UNGMTheta(), 10, **kw)


def _dpf(**kw):
    from pfrepro.filters.dual_pf import DualParticleFilter
    from pfrepro.models.ungm_theta import UNGMTheta

    return DualParticleFilter(UNGMTheta(), 10, 10, **kw)


def _ungm_theta(**kw):
    from pfrepro.models.ungm_theta import UNGMTheta

    return UNGMTheta(**kw)


def _immpf(**kw):
    from pfrepro.filters.imm import IMMParticleFilter
    from pfrepro.models import CWPA, JumpMarkovSystem

    m = CWPA.zhang2016()
    return IMMParticleFilter(JumpMarkovSystem([m, m], [[0.9, 0.1], [0.1, 0.9]]), 10, **kw)


def unit_ball_volume(d):
    from pfrepro.filters.imm import unit_ball_volume as u

    return u(d)


def _ekf(**kw):
    from pfrepro.filters import ExtendedKalmanFilter
    return ExtendedKalmanFilter(UNG, **kw)


def _ukf(**kw):
    from pfrepro.filters import UnscentedKalmanFilter
    return UnscentedKalmanFilter(UNG, **kw)


def _grid(**kw):
    from pfrepro.filters import GridFilter
    return GridFilter(UNG, bounds=(-40.0, 40.0), n_grid=1601, **kw)


def filter_streams(seed, name, runs):
    from pfrepro.montecarlo import filter_streams as fs
    return fs(seed, name, runs)


bad_policy = st.one_of(st.text(max_size=6).filter(lambda t: t not in ("warn", "drop", "raise")), st.none(),
                       st.integers(), st.lists(st.text(max_size=2), max_size=2))


TABLE = [
    # (label, call with the bad value, parameter name the message must contain, bad values)
    ("check_positive_int", lambda v: check_positive_int(v, "n"), "n", bad_count),
    ("as_finite_float", lambda v: as_finite_float(v, "x"), "x", st.one_of(nonfinite, not_a_number)),
    ("check_probability", lambda v: check_probability(v, "p"), "p",
     st.one_of(nonfinite, not_a_number, st.floats(min_value=1.0, exclude_min=True, allow_infinity=False),
               st.floats(max_value=0.0, exclude_max=True, allow_infinity=False))),
    ("run_monte_carlo seed", lambda v: _mc(seed=v), "seed", bad_seed),
    ("run_monte_carlo runs", lambda v: _mc(runs=v), "runs", bad_count),
    ("run_monte_carlo T", lambda v: _mc(T=v), "T", bad_count),
    ("RunStreams.from_entropy runs", lambda v: RunStreams.from_entropy(0, v), "runs", bad_count),
    ("RunStreams.from_entropy entropy", lambda v: RunStreams.from_entropy(v, 2), "entropy",
     st.one_of(st.integers(max_value=-1), st.floats(), st.text(min_size=1, max_size=3))),
    ("BootstrapParticleFilter n_particles", lambda v: BootstrapParticleFilter(UNG, v), "n_particles", bad_count),
    ("GPFF n_particles", lambda v: GaussianParticleFlowFilter(UNG, v), "n_particles", bad_count),
    ("GPFF n_steps", lambda v: GaussianParticleFlowFilter(UNG, 10, n_steps=v), "n_steps", bad_count),
    ("GPFF max_growth", lambda v: GaussianParticleFlowFilter(UNG, 10, max_growth=v), "max_growth",
     st.one_of(nonfinite, not_a_number, st.floats(max_value=1.0, allow_infinity=False))),
    ("LiuWestFilter quantiles", lambda v: _lw(quantiles=v), "quantiles", bad_levels),
    ("LiuWestFilter delta", lambda v: _lw(delta=v), "delta", st.one_of(nonfinite, not_a_number)),
    ("DualParticleFilter nu_min", lambda v: _dpf(nu_min=v), "nu_min",
     st.one_of(nonfinite, not_a_number, st.floats(max_value=0.0, allow_infinity=False))),
    ("DualParticleFilter cap", lambda v: _dpf(cap=v), "cap",
     st.one_of(nonfinite, st.text(max_size=3), st.floats(max_value=0.0, allow_infinity=False))),
    ("DualParticleFilter roughening", lambda v: _dpf(roughening=v), "roughening",
     st.one_of(nonfinite, st.text(max_size=3), st.floats(max_value=0.0, allow_infinity=False))),
    ("UNGMTheta beta", lambda v: _ungm_theta(beta=v), "beta", st.one_of(nonfinite, not_a_number)),
    ("UNGMTheta bounds", lambda v: _ungm_theta(bounds=v), "bounds",
     st.one_of(st.tuples(st.floats()), st.tuples(st.floats(), st.floats(), st.floats()), nonfinite,
               st.tuples(st.floats(min_value=0.6, max_value=10), st.floats(min_value=0.6, max_value=10)))),
    ("unit_ball_volume d", lambda v: unit_ball_volume(v), "d", bad_count),
    ("IMMParticleFilter n_th", lambda v: _immpf(n_th=v), "n_th",
     st.one_of(nonfinite, not_a_number, st.floats(min_value=1.0, exclude_min=True, allow_infinity=False),
               st.floats(max_value=0.0, exclude_max=True, allow_infinity=False))),
    ("GPFF max_shift", lambda v: GaussianParticleFlowFilter(UNG, 10, max_shift=v), "max_shift",
     st.one_of(nonfinite, not_a_number, st.floats(max_value=0.0, allow_infinity=False))),
    # issue 34: the Kalman family's divergence policy, the grid's mass tolerance, stream names, draws
    ("ExtendedKalmanFilter on_divergence", lambda v: _ekf(on_divergence=v), "on_divergence", bad_policy),
    ("UnscentedKalmanFilter on_divergence", lambda v: _ukf(on_divergence=v), "on_divergence", bad_policy),
    ("GridFilter lost_mass_tol", lambda v: _grid(lost_mass_tol=v), "lost_mass_tol",
     st.one_of(nonfinite, not_a_number, st.floats(min_value=1.0, exclude_min=True, allow_infinity=False),
               st.floats(max_value=0.0, exclude_max=True, allow_infinity=False))),
    ("filter_streams name", lambda v: filter_streams(0, v, 2), "name",
     st.one_of(st.integers(), st.none(), st.floats(), st.binary(max_size=3))),
    ("RunStreams.normal scale", lambda v: RunStreams.from_entropy(0, 2).normal(0.0, v, size=(2, 3)), "scale",
     st.floats(max_value=0.0, exclude_max=True, allow_infinity=False)),
]


@pytest.mark.parametrize("label, call, name, values", TABLE, ids=[r[0] for r in TABLE])
def test_bad_values_give_clear_errors(label, call, name, values):
    @settings(max_examples=25, deadline=None, suppress_health_check=list(HealthCheck))
    @given(values)
    def check(v):
        try:
            call(v)
        except (ValueError, TypeError) as exc:
            assert name in str(exc), f"{label}({v!r}): the message does not name {name!r}: {exc}"
            assert type(exc).__module__ in ("builtins", "pfrepro.models.base"), \
                f"{label}({v!r}): {type(exc).__module__}.{type(exc).__name__}"
        else:
            raise AssertionError(f"{label}({v!r}) was accepted")

    check()


# -- exports and the command line --------------------------------------------------------------
def test_write_table_and_to_csv_checks(tmp_path):
    import pandas as pd

    from pfrepro.export import write_table

    with pytest.raises(TypeError, match="DataFrame"):
        write_table(np.zeros((2, 2)), tmp_path / "a.csv")
    with pytest.raises(IsADirectoryError, match="directory"):
        write_table(pd.DataFrame({"a": [1]}), tmp_path)
    res = _mc()
    with pytest.raises(IsADirectoryError, match="directory"):
        res.results["PF"].to_csv(tmp_path)
    assert write_table(pd.Series([1.0, 2.0], name="v"), tmp_path / "s.csv").read_text() == "v\n1.0\n2.0\n"


@pytest.mark.parametrize("content", ["{not json", "[1, 2]", '{"a": 1}', '[{"claim_id": "x"}]'])
def test_scorecard_on_a_corrupt_claims_file_is_one_line_and_exit_2(tmp_path, capsys, content):
    from pfrepro import cli

    (tmp_path / "bad.json").write_text(content)
    code = cli.main(["scorecard", "--dir", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and "bad.json" in err, err


def test_run_with_an_empty_out_is_refused(capsys):
    from pfrepro import cli

    assert cli.main(["run", "li2012", "--runs", "2", "--out", ""]) == 2
    assert "--out" in capsys.readouterr().err


def test_theta_quantiles_refuse_levels_outside_0_1():
    from pfrepro.experiments.dpf_hou2008 import model_51
    from pfrepro.filters.dual_ekf import DualExtendedKalmanFilter
    from pfrepro.filters.dual_pf import DualParticleFilter

    m = model_51()
    y = m.simulate(4, 2, np.random.default_rng(0)).y
    for filt in (DualExtendedKalmanFilter(m, 0.5, 0.1), DualParticleFilter(m, 20, 20)):
        res = filt.filter(y, np.random.default_rng(1))
        for bad in ([1.5], [0.0], [], "0.5"):
            with pytest.raises((ValueError, TypeError), match="q"):
                filt.theta_quantiles(res, bad)
        assert np.all(np.isfinite(filt.theta_quantiles(res, [0.1, 0.9])))


def test_parameterized_model_theta_true_inside_bounds():
    from pfrepro.models.ungm_theta import UNGMTheta

    with pytest.raises(ValueError, match="theta_true.*outside bounds"):
        UNGMTheta(theta_true=1.5, bounds=(0.0, 1.0))
    with pytest.raises(ValueError, match="bounds"):
        UNGMTheta(bounds=(0,))
    from pfrepro.models.linear_theta import LinearTheta
    from pfrepro.models.reentry import Reentry

    for make in (lambda: LinearTheta(theta_true=2.0), lambda: LinearTheta(theta_true=0.5, bounds=(0.6, 0.9)),
                 lambda: Reentry(theta_true=-5.0), lambda: Reentry(theta_true=0.003)):
        with pytest.raises(ValueError, match="theta_true.*outside bounds"):
            make()
    LinearTheta(theta_true=0.7)
    Reentry(theta_true=0.001)


def test_jump_markov_and_imm_mismatches():
    from pfrepro.filters import IMMKalman, KalmanFilter
    from pfrepro.models import JumpMarkovSystem, LinearGaussianModel

    F1, F2 = np.array([[1.0, 1.0], [0.0, 1.0]]), np.array([[1.0, 1.0], [0.0, 0.5]])
    H, Q, R = np.array([[1.0, 0.0]]), 0.1 * np.eye(2), np.array([[2.0]])
    ms = [LinearGaussianModel(F, H, Q, R, x0=[0.0, 1.0], P0=np.eye(2)) for F in (F1, F2)]
    sysm = JumpMarkovSystem(ms, [[0.9, 0.1], [0.1, 0.9]])
    with pytest.raises(ValueError, match=r"mode_filters\[1\]"):
        IMMKalman(sysm, [KalmanFilter(ms[0]), KalmanFilter(ms[0])])      # mode 1's filter on mode 0's model
    IMMKalman(sysm, [KalmanFilter(m) for m in ms])
    twin = LinearGaussianModel(F2, H, Q, R, x0=[0.0, 1.0], P0=np.eye(2))   # an equal copy is fine
    IMMKalman(sysm, [KalmanFilter(ms[0]), KalmanFilter(twin)])
    with pytest.raises(TypeError, match="JumpMarkovSystem"):
        IMMKalman(ms[0], [KalmanFilter(ms[0])])
    with pytest.raises(TypeError, match=r"models\[1\]"):
        JumpMarkovSystem([ms[0], "CV"], np.eye(2))
    other_R = LinearGaussianModel(F2, H, Q, 5 * R, x0=[0.0, 1.0], P0=np.eye(2))
    with pytest.raises(ValueError, match=r"models\[1\].R differs"):
        JumpMarkovSystem([ms[0], other_R], np.eye(2))
    other_P0 = LinearGaussianModel(F2, H, Q, R, x0=[0.0, 1.0], P0=2 * np.eye(2))
    with pytest.raises(ValueError, match=r"models\[1\].P0 differs"):
        JumpMarkovSystem([ms[0], other_P0], np.eye(2))
