"""Tests for the chaos carriers, CMS-PF, its oracle and the ESPF reconstruction (Ning et al. 2011)."""
import numpy as np
import pytest

from pfrepro import published
from pfrepro.chaos import ChaosCarrier, chebyshev_sequence, gaussian_sequence, logistic_sequence
from pfrepro.filters import (BootstrapParticleFilter, CMSParticleFilter, EvolutionSamplingParticleFilter,
                             OracleCMSParticleFilter)
from pfrepro.filters.cmspf import map_particles, select_top_likelihood
from pfrepro.filters.espf import sbx_children
from pfrepro.models import UNGM
from pfrepro.montecarlo import run_monte_carlo


# -- chaos generators ----------------------------------------------------------------------
def test_logistic_range_and_equation():
    s = logistic_sequence(5000, x0=0.3, burn_in=0)
    assert s.shape == (5000,)
    assert np.all((s > 0) & (s < 1))
    np.testing.assert_allclose(s[1:], 4.0 * s[:-1] * (1 - s[:-1]), rtol=0, atol=1e-12)   # eq (1)
    assert s.max() > 0.99 and s.min() < 0.01   # onto (0, 1) for u = 4


def test_chebyshev_range_mean_and_equation():
    s = chebyshev_sequence(20000, x0=0.3, burn_in=100)
    assert np.all((s > -1) & (s < 1))
    np.testing.assert_allclose(s[1:], 1.0 - 2.0 * s[:-1] ** 2, atol=1e-12)            # eq (6), corrected
    assert abs(s.mean()) < 0.03                                                        # zero mean
    assert abs(np.corrcoef(s[:-1], s[1:])[0, 1]) < 0.03                                # white-noise-like


def test_burn_in_is_a_shift_and_generators_deterministic():
    a = logistic_sequence(50, x0=0.123, burn_in=0)
    b = logistic_sequence(40, x0=0.123, burn_in=10)
    np.testing.assert_array_equal(a[10:], b)
    np.testing.assert_array_equal(chebyshev_sequence(30, 0.7, 5), chebyshev_sequence(30, 0.7, 5))
    c1 = ChaosCarrier("chebyshev").generate(7, (3, 4, 1), np.random.default_rng(5))
    c2 = ChaosCarrier("chebyshev").generate(7, (3, 4, 1), np.random.default_rng(5))
    np.testing.assert_array_equal(c1, c2)
    assert c1.shape == (7, 3, 4, 1)
    g = gaussian_sequence(6, np.random.default_rng(1), (2,))
    assert g.shape == (6, 2)


def test_chains_vectorised_and_no_collapse():
    x0 = np.random.default_rng(0).uniform(0.01, 0.99, (200, 50))
    s = logistic_sequence(1000, x0, burn_in=1000)
    assert s.shape == (1000, 200, 50)
    assert np.all((s > 0) & (s < 1))
    assert np.std(s[-1]) > 0.2                  # chains have not collapsed onto a fixed point


@pytest.mark.parametrize("bad", [dict(x0=0.0), dict(x0=1.0), dict(x0=0.5), dict(x0=np.nan), dict(u=3.0),
                                 dict(u=4.5), dict(burn_in=-1), dict(burn_in=1.5)])
def test_logistic_rejects_bad_input(bad):
    kw = dict(n=10, x0=0.3)
    kw.update(bad)
    with pytest.raises(ValueError):
        logistic_sequence(**kw)


def test_chebyshev_and_carrier_reject_bad_input():
    for x0 in (-1.0, 1.0, 0.0, 0.5, 2.0):
        with pytest.raises(ValueError):
            chebyshev_sequence(10, x0)
    with pytest.raises((ValueError, TypeError)):
        chebyshev_sequence(0, 0.3)
    with pytest.raises(ValueError):
        ChaosCarrier("lorenz")
    with pytest.raises(TypeError):
        ChaosCarrier("randn").generate(3, (2,), rng=1)


# -- candidate selection and the map -------------------------------------------------------------
def test_selection_keeps_exactly_the_n_highest():
    rng = np.random.default_rng(3)
    ll = rng.normal(size=(6, 40))
    sel = select_top_likelihood(ll, 20)
    assert sel.shape == (6, 20)
    for r in range(6):
        assert len(set(sel[r])) == 20
        np.testing.assert_array_equal(np.sort(ll[r, sel[r]])[::-1], np.sort(ll[r])[::-1][:20])
        assert np.all(np.diff(ll[r, sel[r]]) <= 0)            # sorted, largest first
    unsorted = select_top_likelihood(ll, 20, sort=False)
    np.testing.assert_array_equal(np.sort(unsorted, 1), np.sort(sel, 1))
    ll[0, 5] = np.nan                                          # NaN never beats a number
    assert 5 not in select_top_likelihood(ll, 39)[0]
    with pytest.raises(ValueError):
        select_top_likelihood(ll, 41)
    with pytest.raises(ValueError):
        select_top_likelihood(ll[0], 3)


def test_map_particles_formula():
    x = np.array([[[0.0], [1.0], [2.0], [3.0]]])            # weights increase with x
    lw = np.log(np.array([[0.1, 0.2, 0.3, 0.4]]))
    r = np.full((1, 4, 1), 0.5)
    x2, lwm, idx = map_particles(x, lw, np.zeros((1, 4)), r, eta=2.0, n_big=1)
    xhat = 0.1 * 0 + 0.2 * 1 + 0.3 * 2 + 0.4 * 3
    # centres cycle x_hat, big; spread big - small = 3 - 0
    np.testing.assert_allclose(x2[0, :, 0], [xhat + 3.0, 3 + 3.0, xhat + 3.0, 3 + 3.0])
    oracle, _, _ = map_particles(x, lw, np.zeros((1, 4)), r, eta=2.0, n_big=1, centre=np.array([[10.0]]))
    np.testing.assert_allclose(oracle[0, :, 0], 13.0)


def test_cms_step_keeps_n_best_and_normalised_weights():
    m = UNGM.ning2011(1.0)
    f = CMSParticleFilter(m, 30, carrier="chebyshev")
    rng = np.random.default_rng(0)
    x = f.sample_prior(rng, (4, 30))
    logw = np.full((4, 30), -np.log(30))
    r = f.carrier.generate(1, (4, 30, 1), rng)[0]
    st = f.step(x, logw, np.array([[2.0]] * 4), 1, r, rng)
    assert st.x.shape == (4, 30, 1)
    np.testing.assert_allclose(np.exp(st.logw).sum(axis=1), 1.0)
    pooled = np.concatenate([st.ll_pred, st.ll_map], axis=1)
    for k in range(4):
        kept = pooled[k, st.selected[k]]
        assert len(set(st.selected[k])) == 30
        assert kept.min() >= np.sort(pooled[k])[::-1][29] - 1e-12


def test_cms_filter_batched_shapes_and_determinism():
    m = UNGM.ning2011(1.0)
    sim = m.simulate(15, 5, np.random.default_rng(1))
    f = CMSParticleFilter(m, 40)
    a = f.filter(sim.y, np.random.default_rng(2))
    b = f.filter(sim.y, np.random.default_rng(2))
    assert a.x.shape == (5, 15, 1) and a.P.shape == (5, 15, 1, 1)
    np.testing.assert_array_equal(a.x, b.x)
    assert np.all(np.isfinite(a.x))
    assert a.diagnostics["likelihood_evaluations"] == 2 * 40 * 15
    never = CMSParticleFilter(m, 40, n_th=0.0).filter(sim.y, np.random.default_rng(2))
    assert not never.diagnostics["resampled"].any()


def test_cms_and_oracle_validation():
    m = UNGM.ning2011(1.0)
    for kw in (dict(n_particles=0), dict(n_particles=1), dict(n_particles=10, eta=0.0),
               dict(n_particles=10, eta=np.nan), dict(n_particles=10, n_th=1.5),
               dict(n_particles=10, big_fraction=-0.1), dict(n_particles=10, carrier="x"),
               dict(n_particles=10, resampling="bogus")):
        with pytest.raises((ValueError, TypeError)):
            CMSParticleFilter(m, **kw)
    f = CMSParticleFilter(m, 10)
    with pytest.raises(ValueError):
        f.filter(np.array([1.0, np.nan, 2.0]), np.random.default_rng(0))
    with pytest.raises(TypeError):
        f.filter(np.ones(5), rng=None)
    with pytest.raises(ValueError):
        f.filter(np.ones((2, 5, 1)), np.random.default_rng(0), r=np.zeros((5, 2, 9, 1)))
    sim = m.simulate(5, 2, np.random.default_rng(0))
    o = OracleCMSParticleFilter(m, 10)
    with pytest.raises(TypeError, match="TRUE state"):
        o.filter(sim.y, np.random.default_rng(0))              # no accidental use
    with pytest.raises(TypeError):                              # the Monte Carlo runner cannot run it either
        run_monte_carlo(m, {"oracle": o}, 5, 2, seed=0)
    with pytest.raises(ValueError):
        o.filter(sim.y, np.random.default_rng(0), x_true=sim.x[:, 1:])
    res = o.filter(sim.y, np.random.default_rng(0), x_true=sim.x)
    assert res.x.shape == (2, 5, 1)


# -- ESPF reconstruction ---------------------------------------------------------------------------
def test_sbx_children_preserve_mean_and_validate():
    rng = np.random.default_rng(0)
    p1, p2 = rng.normal(size=100), rng.normal(size=100)
    u = rng.uniform(0.01, 0.99, 100)
    c1, c2 = sbx_children(p1, p2, u, 2.0)
    np.testing.assert_allclose(c1 + c2, p1 + p2)
    c1, c2 = sbx_children(p1, p2, np.full(100, 0.5), 2.0)       # b = 1: children = parents
    np.testing.assert_allclose(c1, p1)
    with pytest.raises(ValueError):
        sbx_children(p1, p2, np.zeros(100), 2.0)
    with pytest.raises(ValueError):
        sbx_children(p1, p2, u, -1.0)


def test_espf_runs_and_validates():
    m = UNGM.ning2011(1.0)
    sim = m.simulate(10, 3, np.random.default_rng(0))
    res = EvolutionSamplingParticleFilter(m, 31).filter(sim.y, np.random.default_rng(1))
    assert res.x.shape == (3, 10, 1) and np.all(np.isfinite(res.x))
    np.testing.assert_allclose(res.diagnostics["origin_share"].sum(axis=2), 1.0)
    for kw in (dict(n_particles=1), dict(n_particles=10, mcmc_scale=0.0), dict(n_particles=10, sbx_eta=-2)):
        with pytest.raises(ValueError):
            EvolutionSamplingParticleFilter(m, **kw)


def test_cms_tracks_reasonably():
    """Sanity: CMS-PF is far better than a filter that ignores the data, and finite."""
    m = UNGM.ning2011(1.0)
    sim = m.simulate(50, 20, np.random.default_rng(4))
    e = CMSParticleFilter(m, 100).filter(sim.y, np.random.default_rng(5)).x
    p = BootstrapParticleFilter(m, 100).filter(sim.y, np.random.default_rng(5)).x
    rm = lambda z: np.sqrt(np.mean((z - sim.x[:, 1:]) ** 2))
    assert rm(e) < 2.5 * rm(p)
    assert rm(e) < np.sqrt(np.mean(sim.x[:, 1:] ** 2))


# -- published data ------------------------------------------------------------------------------
def test_published_tables_complete_and_consistent():
    t1 = published.table("cmspf_ning2011", "Table 1")
    t3 = published.table("cmspf_ning2011", "Table 3")
    t2 = published.table("cmspf_ning2011", "Table 2")
    assert t1.shape == (22, 10) and t3.shape == (22, 8) and t2.shape == (2, 5)
    runs = t1.loc[[str(i) for i in range(1, 21)]]
    np.testing.assert_allclose(runs.mean().values, t1.loc["21"].values, atol=6e-4)
    np.testing.assert_allclose(runs.var(ddof=1).values, t1.loc["22"].values, atol=6e-4)
    assert published.value("cmspf_ning2011", "Table 2", "RMSE", "CMS-PF") == pytest.approx(5.2070)
    assert published.value("cmspf_ning2011", "Table 3", "1", "EKF") == pytest.approx(30.0065)


# -- free choices of the chapter (issue 24) and the mechanism measures (issue 19) ------------
from pfrepro.choices import FIXED, as_choice_map  # noqa: E402
from pfrepro.experiments import cmspf_ning2011 as E  # noqa: E402
from pfrepro.figures import cmspf_ning2011 as F  # noqa: E402
from pfrepro.rng import RunStreams  # noqa: E402


@pytest.mark.parametrize("kind", ["logistic", "chebyshev"])
def test_carrier_initialisations_layout(kind):
    T, runs, N = 4, 3, 5
    run = ChaosCarrier(kind, init="run", burn_in=10).generate(T, (runs, N, 1), RunStreams.from_entropy(7, runs))
    shared = ChaosCarrier(kind, init="shared", burn_in=10).generate(T, (runs, N, 1), RunStreams.from_entropy(7, runs))
    step = (lambda x: 4 * x * (1 - x)) if kind == "logistic" else (lambda x: 1 - 2 * x ** 2)
    for r in (run, shared):
        assert r.shape == (T, runs, N, 1)
        seq = r[:, 0, :, 0].ravel()            # run 0: slots of step 1, then of step 2, ...
        np.testing.assert_allclose(seq[1:], step(seq[:-1]), atol=1e-9)
    assert np.array_equal(shared[:, 0], shared[:, 2])          # one sequence for every run
    assert not np.array_equal(run[:, 0], run[:, 2])            # one chain per run
    other = ChaosCarrier(kind, init="shared", burn_in=10).generate(T, (runs, N, 1), RunStreams.from_entropy(8, runs))
    assert np.array_equal(shared, other)                       # fixed start: no randomness
    # run i is the same in a batch of 1 and of 3 (per-run streams)
    one = ChaosCarrier(kind, init="run", burn_in=10).generate(T, (1, N, 1), RunStreams.from_entropy(7, 3).subset([2]))
    np.testing.assert_array_equal(one[:, 0], run[:, 2])
    with pytest.raises(ValueError):
        ChaosCarrier(kind, init="random")


def test_experiment_passes_u_burn_in_and_init_to_the_filter():
    m = E.model()
    f = E.cms(m, 20)
    assert (f.carrier.kind, f.carrier.u, f.carrier.burn_in, f.carrier.init) == (
        E.ASSUMPTIONS["carrier"], E.ASSUMPTIONS["u"], E.ASSUMPTIONS["burn_in"], E.ASSUMPTIONS["init"])
    g = E.cms(m, 20, u=3.8, burn_in=100, init="shared", eta=0.2, big_fraction=1e-9)
    assert (g.carrier.u, g.carrier.burn_in, g.carrier.init, g.eta, g.n_big) == (3.8, 100, "shared", 0.2, 1)


def test_choices_rows_and_readings_name_choices():
    cmap = as_choice_map(E.CHOICES)
    for (c, _v) in E.CMS_READINGS:
        assert c in cmap and cmap[c].status != FIXED
    for tag in list(E.T2_READINGS) + list(E.T3_TAGS.values()):
        for part in tag.split(","):
            assert part.split("=")[0].strip() in cmap
    assert {"u", "burn_in", "carrier_init"} <= set(cmap)


def test_set_stats_hand_case():
    s = E.set_stats(np.array([[1.0, 1.0, 2.0, 3.0], [0.0, 1.0, 2.0, 3.0]]))
    np.testing.assert_allclose(s["distinct"], [0.75, 1.0])
    np.testing.assert_array_equal(s["duplicates"], [1, 0])
    # sorted u = (0, 0, .5, 1): max(i/M - u) = .5; evenly spaced (0, 1/3, 2/3, 1): 0.25
    np.testing.assert_allclose(s["ks"], [0.5, 0.25])


def test_trend_slopes_and_carrier_counts():
    import pandas as pd
    Ns = [10, 100, 1000]
    t = pd.DataFrame([[3 - 2 * np.log(n) for n in Ns], [1.0, 1.0, 1.0]], columns=Ns)
    np.testing.assert_allclose(E.trend_slopes(t), [-2.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(E.trend_slopes(t, N_min=100), [-2.0, 0.0], atol=1e-12)
    c = E.carrier_iterations(10, T_=50, burn_in=1000, init="chain", runs=2)
    assert c == {"carrier iterations": 2 * 10 * 1050, "model evaluations": 2 * 3 * 10 * 50}
    assert E.carrier_iterations(10, 50, 1000, "shared", runs=2)["carrier iterations"] == 1000 + 500


def test_printed_digits_and_divisors():
    p3 = F.printed("Table 3")
    assert p3.loc["22", "EKF"] == "179.3805" and p3.loc["21", "CMSR3-PF"] == "4.2601"
    assert float(p3.loc["22", "EKF"]) == published.value(E.PAPER, "Table 3", "22", "EKF")
    d3, d1 = F.divisor_check("Table 3"), F.divisor_check("Table 1")
    assert d3.loc["CMSR1-PF", "divisor that matches"] == "n"        # the divisor slip
    assert d3.loc["UKF", "divisor that matches"] == "neither"       # misprinted rows
    assert set(d3.drop(["CMSR1-PF", "UKF"])["divisor that matches"]) == {"n − 1"}
    assert set(d1["divisor that matches"]) == {"n − 1"}
    # every published number shown in the chapter's tables is the printed string
    s1 = F.table1_summary(pd_table1_dummy())
    assert list(s1["PF paper"]) == [F.printed("Table 1").loc["21", f"N={N} PF"] for N in E.TABLE1_N]


def pd_table1_dummy():
    import pandas as pd
    cols = pd.MultiIndex.from_tuples([(N, f) for N in E.TABLE1_N for f in ("PF", "CMS-PF", "PF (2N)")])
    return pd.DataFrame(np.ones((20, len(cols))), columns=cols)


def test_mechanism_runs_and_orders_sets():
    d = E.mechanism(runs=2, N=20)
    m = d.mean()
    assert m[("CMS-PF candidates (2N)", "distinct")] == 1.0
    assert m[("PF resampled set", "distinct")] < 1.0
    assert m[("PF resampled set", "duplicates")] > 0


def test_step_k_uses_carrier_slice_k_minus_1_and_truth_k():
    """Step k maps with r[k-1] (the carrier's k-th value) and, in the oracle, centres on x_k:
    a one-step shift of either (r[k-2], r[k], x_true[:, k-1]) would move estimates of steps that
    must not see the change (mutation testing found the shift unpinned)."""
    m = UNGM.ning2011()
    T, runs, N = 5, 2, 20
    sim = m.simulate(T, runs, np.random.default_rng(3))
    f = CMSParticleFilter(m, N)
    r = f.carrier.generate(T, (runs, N, 1), np.random.default_rng(4))
    ref = f.filter(sim.y, np.random.default_rng(5), r=r)
    np.testing.assert_array_equal(ref.x, f.filter(sim.y, np.random.default_rng(5), r=r.copy()).x)
    for k in range(1, T + 1):                      # changing r[k-1] leaves steps 1..k-1 alone, moves step k
        r2 = r.copy()
        r2[k - 1] = 1.0 - r2[k - 1] ** 2 / 2
        got = f.filter(sim.y, np.random.default_rng(5), r=r2)
        np.testing.assert_array_equal(got.x[:, :k - 1], ref.x[:, :k - 1])
        assert not np.array_equal(got.x[:, k - 1], ref.x[:, k - 1]), k
    # the oracle centres the map particles of step k on x_k: moving x_T only changes step T
    o = OracleCMSParticleFilter(m, N)
    base = o.filter(sim.y, np.random.default_rng(5), x_true=sim.x)
    xt = sim.x.copy()
    xt[:, T] += 7.0
    moved = o.filter(sim.y, np.random.default_rng(5), x_true=xt)
    np.testing.assert_array_equal(moved.x[:, :T - 1], base.x[:, :T - 1])
    assert not np.array_equal(moved.x[:, T - 1], base.x[:, T - 1])


def test_offline_carrier_counts_map_iterations_outside_the_loop():
    """Counted, not assumed: the online call iterates the map N (T0 + T) times (chain layout), the
    call with a precomputed carrier none; a randn carrier has no map to move offline (no saving)."""
    from pfrepro.experiments import cmspf_ning2011 as E
    o = E.carrier_operations(N=20, burn_in=30)
    assert o["online"]["map iterations"] * E.T == 20 * (30 + E.T)
    assert o["offline"]["map iterations"] == 0 and o["offline before the loop"] == 20 * (30 + E.T)
    assert o["online"]["model evaluations"] == o["offline"]["model evaluations"] == 3 * 20
    assert o["offline"]["operations"] < o["online"]["operations"]
    r = E.carrier_operations(N=20, carrier="randn")
    assert r["offline"]["operations"] == r["online"]["operations"]


def test_sensitivity_keys_are_the_cms_readings():
    """Table 2's CMS-PF readings are read off the sensitivity sweep (E.SENS_KEY): the same readings,
    and the same number of big/small pairs (n_big = 1 is 0.5 % of N = 200 in the sweep)."""
    assert set(E.SENS_KEY) == set(E.CMS_TAGS)
    m = E.model()
    for t in E.CMS_TAGS:
        par, v = E.SENS_KEY[t]
        assert v in E.SENSITIVITY_GRID[par]
        assert E.cms(m, 200, **E.CMS_TAGS[t]).n_big == E.cms(m, 200, **{par: v}).n_big
