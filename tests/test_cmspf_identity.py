"""The faster CMS-PF, ESPF and chaos carriers give the numbers of the plain reading, bit for bit.

Each test runs the code of the package against a reference computed here by the algorithm as
first written (the chaos maps as ``u (1 - x) x`` clipped by minimum and maximum, the big/small
particles by two ``select_top_likelihood`` calls, gathers by ``take_along_axis``, the
resampling through ``resample_counts``, ESPF's loop by :func:`espf_loop_reference`), and
compares the bytes of every output.
"""
import types

import numpy as np
import pytest

from pfrepro.chaos import EDGE, ChaosCarrier, chebyshev_sequence, logistic_sequence
from pfrepro.filters import CMSParticleFilter, EvolutionSamplingParticleFilter, OracleCMSParticleFilter
from pfrepro.filters import cmspf as C
from pfrepro.filters.cmspf import CMSStep, map_particles, select_top_likelihood
from pfrepro.filters.espf import _sbx, sbx_children
from pfrepro.filters.base import FilterDivergenceError
from pfrepro.filters.particle import normalize_log_weights
from pfrepro.filters.resampling import resample, resample_counts
from pfrepro.models import UNGM
from pfrepro.rng import RunStreams, take_runs


def same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


# -- the plain reading, as first written ---------------------------------------------------
def logistic_ref(n, x0, u, burn_in):
    x = np.array(x0, dtype=float)
    out = np.empty((n,) + x.shape)
    for i in range(burn_in + n):
        t = (1.0 - x) * x * u
        x = np.maximum(np.minimum(t, 1.0 - EDGE), EDGE)
        if i >= burn_in:
            out[i - burn_in] = x
    return out


def chebyshev_ref(n, x0, burn_in):
    x = np.array(x0, dtype=float)
    out = np.empty((n,) + x.shape)
    for i in range(burn_in + n):
        t = x * x * -2.0 + 1.0
        x = np.maximum(np.minimum(t, 1.0 - EDGE), -1.0 + EDGE)
        if i >= burn_in:
            out[i - burn_in] = x
    return out


def map_particles_ref(x_pred, lw_pred, logw_prev, r, eta, n_big, centre=None):
    M = r.shape[1]
    big = select_top_likelihood(lw_pred, n_big)
    small = select_top_likelihood(-np.where(np.isnan(lw_pred), -np.inf, lw_pred), n_big)
    xb = np.take_along_axis(x_pred, big[..., None], axis=1)
    xs = np.take_along_axis(x_pred, small[..., None], axis=1)
    spread = xb - xs
    lwb = np.take_along_axis(logw_prev, big, axis=1)
    if centre is None:
        w, _, _ = normalize_log_weights(lw_pred)
        xhat = (w[:, None, :] @ x_pred)
        centres = np.concatenate([xhat, xb], axis=1)
        spreads = np.concatenate([spread[:, :1], spread], axis=1)
        lwc = np.concatenate([lwb[:, :1], lwb], axis=1)
    else:
        centres = np.broadcast_to(np.asarray(centre, float)[:, None, :], xb.shape)
        spreads, lwc = spread, lwb
    idx = np.arange(M) % centres.shape[1]
    return centres[:, idx] + eta * r * spreads[:, idx], lwc[:, idx], idx


def step_ref(self, x_prev, logw_prev, y_k, k, r, rng, x_true_k=None, use_map=True):
    N = self.n_particles
    x1 = self.model.sample_transition(x_prev, k, rng)
    ll1 = self.model.log_likelihood(y_k, x1)
    x2, lw2_prev, _ = map_particles_ref(x1, logw_prev + ll1, logw_prev, r, self.eta, self.n_big, x_true_k)
    ll2 = self.model.log_likelihood(y_k, x2)
    xc = np.concatenate([x1, x2], axis=1)
    llc = np.concatenate([ll1, ll2], axis=1)
    lwc_prev = np.concatenate([logw_prev, lw2_prev], axis=1)
    sel = select_top_likelihood(llc, N, sort=False)
    x = np.take_along_axis(xc, sel[..., None], axis=1)
    lw = np.take_along_axis(lwc_prev, sel, axis=1) + np.take_along_axis(llc, sel, axis=1)
    w, _, coll = normalize_log_weights(lw)
    with np.errstate(divide="ignore"):
        logw = np.log(w)
    est = (w[:, None, :] @ x)[:, 0]
    return CMSStep(x1, ll1, x2, ll2, sel, x, logw, est, coll)


def loop_ref(self, y, rng, x_true, carrier, x, logw, xs, Ps, ess, resampled, map_share, collapsed):
    runs, T, _ = y.shape
    N, n = self.n_particles, self.model.dim_x
    for k in range(1, T + 1):
        xt = None if x_true is None else x_true[:, k]
        st = step_ref(self, x, logw, y[:, k - 1], k, carrier[k - 1], rng, x_true_k=xt)
        x, logw = st.x, st.logw
        collapsed[:, k - 1] = st.collapsed
        w = np.exp(logw)
        xs[:, k - 1] = st.estimate
        d = x - st.estimate[:, None, :]
        Ps[:, k - 1] = np.einsum("rn,rni,rnj->rij", w, d, d)
        map_share[:, k - 1] = np.mean(st.selected >= N, axis=1)
        neff = np.round(1.0 / np.sum(w * w, axis=1))
        ess[:, k - 1] = neff
        do = neff < self.n_th * N
        if do.any():
            sel = np.flatnonzero(do)
            counts = resample_counts(w[sel], take_runs(rng, sel), self.resampling)
            x = x.copy()
            x[sel] = np.repeat(x[sel].reshape(-1, n), counts.ravel(), axis=0).reshape(len(sel), N, n)
            logw = logw.copy()
            logw[sel] = -np.log(N)
        resampled[:, k - 1] = do


def old_carrier(carrier):
    """``carrier.generate`` with the maps of the plain reading."""
    def generate(T, shape, rng):
        if carrier.kind == "randn" or carrier.init != "chain":
            return ChaosCarrier.generate(carrier, T, shape, rng)
        v = rng.uniform(0.01, 0.99, tuple(shape))
        if carrier.kind == "logistic":
            return logistic_ref(T, v, carrier.u, carrier.burn_in)
        return chebyshev_ref(T, 2.0 * v - 1.0, carrier.burn_in)
    return generate


# -- the carriers --------------------------------------------------------------------------
@pytest.mark.parametrize("u", [4.0, 3.9, 3.6])
def test_logistic_sequence_bit_identical_to_the_plain_map(u):
    x0 = np.random.default_rng(1).uniform(0.01, 0.99, 3000)
    # orbits that reach the clip at both ends: 0.5 + 1e-9 maps to 1 - 4e-18, rounded to 1
    x0[:4] = [0.5 - 1e-9, 0.5 + 1e-9, 1e-12, 0.25]
    assert same(logistic_sequence(300, x0, u, 200), logistic_ref(300, x0, u, 200))


@pytest.mark.parametrize("u", [4.0, 3.7])
def test_logistic_sequence_scalar_start(u):
    assert same(logistic_sequence(50, 0.3, u, 100), logistic_ref(50, 0.3, u, 100))
    assert same(chebyshev_sequence(50, 0.3, 100), chebyshev_ref(50, 0.3, 100))


def test_chebyshev_sequence_bit_identical_to_the_plain_map():
    x0 = np.random.default_rng(2).uniform(-0.99, 0.99, 3000)
    x0[:2] = [1e-9, 0.5 + 1e-12]
    assert same(chebyshev_sequence(300, x0, 200), chebyshev_ref(300, x0, 200))


# -- CMS-PF --------------------------------------------------------------------------------
def _ning(sv=1.0):
    return UNGM(time_offset=0, Q=1.0, R=sv ** 2, x0=0.1, m0=0.0, P0=1.0)


def _ning_with_nan_pools(monkeypatch):
    """Ning's model whose log-likelihood is NaN where the state is below -1 (finite states), and
    8 steps of 3 runs simulated from it: pools holding NaN."""
    m = _ning()
    plain = m.log_likelihood

    def nan_below(y, x):
        out = np.array(plain(y, x))
        out[x[..., 0] < -1.0] = np.nan
        return out

    sim = m.simulate(8, 3, np.random.default_rng(2))
    monkeypatch.setattr(m, "log_likelihood", nan_below)
    return m, sim


CMS_CASES = [dict(N=40), dict(N=40, n_th=1.0), dict(N=30, n_th=0.0, carrier="chebyshev", big_fraction=0.5),
             dict(N=21, carrier="randn", big_fraction=0.01, resampling="multinomial"),
             dict(N=16, carrier=ChaosCarrier("logistic", u=3.9, init="run"), resampling="residual"),
             dict(N=2)]


@pytest.mark.parametrize("case", CMS_CASES)
@pytest.mark.parametrize("streams", [True, False])
@pytest.mark.parametrize("sv", [1.0, 10.0])
def test_cms_filter_bit_identical_to_the_plain_reading(case, streams, sv, monkeypatch):
    kw = dict(case)
    N = kw.pop("N")
    m = _ning(sv)
    sim = m.simulate(25, 6, np.random.default_rng(7))
    rng = (lambda: RunStreams.from_entropy(3, 6)) if streams else (lambda: np.random.default_rng(5))
    new = CMSParticleFilter(m, N, **kw).filter(sim.y, rng())
    old = CMSParticleFilter(m, N, **kw)
    monkeypatch.setattr(old, "_loop", loop_ref.__get__(old))
    monkeypatch.setattr(old.carrier, "generate", old_carrier(old.carrier))
    ref = old.filter(sim.y, rng())
    assert same(new.x, ref.x) and same(new.P, ref.P)
    for key in ("ess", "resampled", "map_share", "collapsed"):
        assert same(new.diagnostics[key], ref.diagnostics[key]), key


@pytest.mark.parametrize("runs", [1, 3, 8])
@pytest.mark.parametrize("N", [7, 40])
@pytest.mark.parametrize("scheme", ["systematic", "stratified", "multinomial", "residual"])
def test_cms_filter_bit_identical_every_batch_size_and_scheme(runs, N, scheme, monkeypatch):
    """Batches of 1, 3 and 8 runs, odd and even N, every scheme, resampling at every step
    (``n_th = 1``) or for some runs only (``n_th = 0.5``), per-run streams and one generator,
    two seeds: the reference's numbers and flags."""
    m = _ning(3.0)
    mixed = 0
    for seed in (1, 6):
        sim = m.simulate(15, runs, np.random.default_rng(200 + seed))
        for make in (lambda: RunStreams.from_entropy(seed, runs), lambda: np.random.default_rng(seed)):
            for n_th in (0.5, 1.0):
                new = CMSParticleFilter(m, N, n_th=n_th, resampling=scheme).filter(sim.y, make())
                old = CMSParticleFilter(m, N, n_th=n_th, resampling=scheme)
                monkeypatch.setattr(old, "_loop", loop_ref.__get__(old))
                monkeypatch.setattr(old.carrier, "generate", old_carrier(old.carrier))
                ref = old.filter(sim.y, make())
                assert same(new.x, ref.x) and same(new.P, ref.P), (seed, n_th)
                for key in ("ess", "resampled", "map_share", "collapsed"):
                    assert same(new.diagnostics[key], ref.diagnostics[key]), (seed, n_th, key)
                r = new.diagnostics["resampled"]
                mixed += int(np.any(r.any(axis=0) & ~r.all(axis=0)))
    if runs > 1:
        assert mixed        # some step resampled some runs only: that branch was compared too


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_cms_nan_likelihoods_take_the_selection_rule(monkeypatch):
    """NaN log-likelihoods in the 2N pool count as -inf in the selection, as in
    ``select_top_likelihood``: the reference's numbers."""
    m, sim = _ning_with_nan_pools(monkeypatch)
    new = CMSParticleFilter(m, 12).filter(sim.y, RunStreams.from_entropy(3, 3))
    old = CMSParticleFilter(m, 12)
    monkeypatch.setattr(old, "_loop", loop_ref.__get__(old))
    monkeypatch.setattr(old.carrier, "generate", old_carrier(old.carrier))
    ref = old.filter(sim.y, RunStreams.from_entropy(3, 3))
    assert same(new.x, ref.x) and same(new.diagnostics["map_share"], ref.diagnostics["map_share"])


def test_select_negated_is_select_top_likelihood_of_the_negation():
    """The filters' selection from negated log-likelihoods gives ``select_top_likelihood``'s
    indices, in its order, with ties, -inf, +inf and NaN (counted as -inf) in the rows."""
    rng = np.random.default_rng(12)
    ll = np.round(rng.standard_normal((6, 90)), 1)            # many ties
    ll[1, :7] = -np.inf
    ll[2, 3:40:3] = np.nan
    ll[3, 5] = np.inf
    ll[4] = np.nan
    for n_keep in (1, 30, 89, 90):
        for rows in (ll, ll[:1], ll[[0, 3, 5]]):
            assert same(C._select_negated(np.negative(rows), n_keep),
                        select_top_likelihood(rows, n_keep, sort=False)), n_keep


def test_oracle_cms_bit_identical(monkeypatch):
    m = _ning()
    sim = m.simulate(20, 5, np.random.default_rng(8))
    new = OracleCMSParticleFilter(m, 30).filter(sim.y, np.random.default_rng(1), x_true=sim.x)
    old = OracleCMSParticleFilter(m, 30)
    monkeypatch.setattr(old, "_loop", loop_ref.__get__(old))
    monkeypatch.setattr(old.carrier, "generate", old_carrier(old.carrier))
    ref = old.filter(sim.y, np.random.default_rng(1), x_true=sim.x)
    assert same(new.x, ref.x) and same(new.P, ref.P)


def test_map_particles_with_ties_nan_and_minus_inf_falls_back_to_the_selections():
    rng = np.random.default_rng(0)
    x = np.repeat(rng.standard_normal((4, 10, 1)), 4, axis=1)
    logw = np.full((4, 40), -np.log(40))
    r = rng.uniform(size=(4, 40, 1))
    lw = np.tile(np.repeat(np.arange(10.0), 4), (4, 1))     # ties everywhere
    lw[1] = rng.standard_normal(40)                         # distinct
    lw[2, :5] = -np.inf                                     # tied -inf among the small
    lw[3] = rng.standard_normal(40)
    for variant in (lw, np.where(np.arange(40) == 3, np.nan, lw)):
        for B in (1, 4, 20):
            got = map_particles(x, variant, logw, r, 0.5, B)
            want = map_particles_ref(x, variant, logw, r, 0.5, B)
            assert all(same(a, b) for a, b in zip(got, want))
    # distinct rows alone take the fast path, with the same answer as the two selections
    d = rng.standard_normal((5, 40))
    big, small = C._big_small(d, 6)
    assert same(big, select_top_likelihood(d, 6)) and same(small, select_top_likelihood(-d, 6))


# -- ESPF ----------------------------------------------------------------------------------
def espf_loop_reference(self, y, rng, x, xs, acc_rate, origin, collapsed, log_trans, Lq):
    """ESPF's loop as first written (fancy indexing, ``resample``, ``rng.uniform``): the reference
    ``EvolutionSamplingParticleFilter._loop`` is held to, bit for bit (bound to a filter as its
    ``_loop``)."""
    runs, T, _ = y.shape
    N, n = self.n_particles, self.model.dim_x
    npair = N // 2
    rows = np.arange(runs)[:, None]
    for k in range(1, T + 1):
        if not np.all(np.isfinite(x)):
            raise FilterDivergenceError(f"ESPF particles became non-finite at step {k}")
        yk = y[:, k - 1]
        m = self.model.f(x, k)                                       # predicted means
        xp = m + rng.standard_normal((runs, N, n)) @ Lq.T
        ll = self.model.log_likelihood(yk, xp)
        w, _, collapsed[:, k - 1] = normalize_log_weights(ll)
        a = resample(w, rng, self.resampling)                        # ancestors (runs, N)
        xr, mr, llr = xp[rows, a], m[rows, a], ll[rows, a]
        prop = xr + self.mcmc_scale * (rng.standard_normal((runs, N, n)) @ Lq.T)
        llp = self.model.log_likelihood(yk, prop)
        log_alpha = llp + log_trans(prop, mr) - llr - log_trans(xr, mr)
        accept = np.log(rng.random((runs, N))) < log_alpha
        xm = np.where(accept[..., None], prop, xr)
        llm = np.where(accept, llp, llr)
        acc_rate[:, k - 1] = accept.mean(axis=1)
        perm = rng.permuted(np.broadcast_to(np.arange(N), (runs, N)), axis=1)
        p1 = xr[rows, perm[:, :npair]]
        p2 = xr[rows, perm[:, npair:2 * npair]]
        u = rng.uniform(np.finfo(float).eps, 1.0 - np.finfo(float).eps, p1.shape)
        c1, c2 = sbx_children(p1, p2, u, self.sbx_eta)
        parts = [c1, c2]
        if N % 2:
            parts.append(xr[rows, perm[:, -1:]])
        xc = np.concatenate(parts, axis=1)
        llc = self.model.log_likelihood(yk, xc)
        pool_x = np.concatenate([xr, xm, xc], axis=1)
        pool_ll = np.concatenate([llr, llm, llc], axis=1)
        sel = select_top_likelihood(pool_ll, N, sort=False)
        x = np.take_along_axis(pool_x, sel[..., None], axis=1)
        xs[:, k - 1] = x.mean(axis=1)
        origin[:, k - 1] = np.stack([(sel < N).mean(1), ((sel >= N) & (sel < 2 * N)).mean(1),
                                     (sel >= 2 * N).mean(1)], axis=1)


@pytest.mark.parametrize("N,scheme", [(40, "systematic"), (31, "multinomial"), (2, "residual")])
@pytest.mark.parametrize("streams", [True, False])
def test_espf_bit_identical_to_its_reference_loop(N, scheme, streams, monkeypatch):
    m = _ning(3.0)
    sim = m.simulate(25, 6, np.random.default_rng(9))
    rng = (lambda: RunStreams.from_entropy(4, 6)) if streams else (lambda: np.random.default_rng(6))
    new = EvolutionSamplingParticleFilter(m, N, resampling=scheme).filter(sim.y, rng())
    old = EvolutionSamplingParticleFilter(m, N, resampling=scheme)
    monkeypatch.setattr(old, "_loop", types.MethodType(espf_loop_reference, old))
    ref = old.filter(sim.y, rng())
    assert same(new.x, ref.x)
    for key in ("acceptance", "origin_share", "collapsed"):
        assert same(new.diagnostics[key], ref.diagnostics[key]), key


ESPF_SCHEMES = ["systematic", "stratified", "multinomial", "residual"]


@pytest.mark.parametrize("runs", [1, 3, 8])
@pytest.mark.parametrize("N", [2, 7, 40])
@pytest.mark.parametrize("scheme", ESPF_SCHEMES)
def test_espf_bit_identical_every_batch_size_scheme_and_parity(runs, N, scheme, monkeypatch):
    """Batches of 1, 3 and 8 runs, odd and even N, every scheme, per-run streams and one shared
    generator, several seeds, a scale of the move other than 1: the filter's estimates and all its
    diagnostics are the reference loop's, byte for byte."""
    m = _ning(2.0)
    for seed in (0, 5):
        sim = m.simulate(12, runs, np.random.default_rng(100 + seed))
        for make in (lambda: RunStreams.from_entropy(seed, runs), lambda: np.random.default_rng(seed)):
            for scale in (1.0, 0.7):
                new = EvolutionSamplingParticleFilter(m, N, mcmc_scale=scale, resampling=scheme).filter(sim.y, make())
                old = EvolutionSamplingParticleFilter(m, N, mcmc_scale=scale, resampling=scheme)
                monkeypatch.setattr(old, "_loop", types.MethodType(espf_loop_reference, old))
                ref = old.filter(sim.y, make())
                assert same(new.x, ref.x), (seed, scale)
                for key in ("acceptance", "origin_share", "collapsed"):
                    assert same(new.diagnostics[key], ref.diagnostics[key]), (seed, scale, key)


def test_espf_bit_identical_for_a_vector_state(monkeypatch):
    """A 2-D state keeps the matrix forms (``e @ Lq.T``, the einsum of ``log_trans``): still the
    reference's numbers."""
    from pfrepro.models.linear import LinearGaussianModel
    m = LinearGaussianModel(F=[[0.9, 0.2], [0.0, 0.8]], H=[[1.0, 0.5]], Q=[[0.5, 0.1], [0.1, 0.3]],
                            R=[[0.4]], x0=[0.3, -0.2])
    sim = m.simulate(10, 3, np.random.default_rng(4))
    for make in (lambda: RunStreams.from_entropy(8, 3), lambda: np.random.default_rng(8)):
        new = EvolutionSamplingParticleFilter(m, 9, mcmc_scale=0.6).filter(sim.y, make())
        old = EvolutionSamplingParticleFilter(m, 9, mcmc_scale=0.6)
        monkeypatch.setattr(old, "_loop", types.MethodType(espf_loop_reference, old))
        ref = old.filter(sim.y, make())
        assert same(new.x, ref.x) and same(new.diagnostics["origin_share"], ref.diagnostics["origin_share"])


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_espf_nan_likelihoods_take_the_selection_rule(monkeypatch):
    """A pool holding NaN log-likelihoods (a model that returns NaN at some states) is selected
    with NaN as -inf, as ``select_top_likelihood`` does: the reference's particles."""
    m, sim = _ning_with_nan_pools(monkeypatch)
    new = EvolutionSamplingParticleFilter(m, 12).filter(sim.y, RunStreams.from_entropy(3, 3))
    old = EvolutionSamplingParticleFilter(m, 12)
    monkeypatch.setattr(old, "_loop", types.MethodType(espf_loop_reference, old))
    ref = old.filter(sim.y, RunStreams.from_entropy(3, 3))
    assert same(new.x, ref.x) and same(new.diagnostics["origin_share"], ref.diagnostics["origin_share"])


def test_shuffle_draws_what_permuted_draws():
    """The ESPF pairs particles by ``Generator.shuffle`` of 0..N-1 in place of ``permuted`` of a
    broadcast 0..N-1 (what ``RunStreams.permuted`` and the reference call): the same permutation
    and the same draws consumed, for small, odd, even and large N."""
    for N in (1, 2, 3, 7, 40, 201, 1000):
        for seed in range(5):
            a, b = np.random.default_rng(seed), np.random.default_rng(seed)
            want = a.permuted(np.broadcast_to(np.arange(N), (2, N))[0], axis=0)
            got = np.arange(N)
            b.shuffle(got)
            assert same(got, want)
            assert same(a.random(3), b.random(3))         # the streams stay in step


def test_scalar_draw_is_the_one_element_draw():
    """The systematic scheme's uniform is drawn as ``Generator.random()`` (a float) where the counts
    function would call ``random`` for one element: the same number, the streams in step."""
    for seed in range(5):
        a, b = np.random.default_rng(seed), np.random.default_rng(seed)
        a.standard_normal(5)
        b.standard_normal(5)
        row = np.empty(1)
        a.random(out=row)
        assert same(np.array([b.random()]), row)
        assert same(a.standard_normal(4), b.standard_normal(4))


def test_scalar_forms_of_the_noise_and_transition_density():
    """For a scalar state, ``e @ Lq.T`` is ``e * Lq + 0.0`` (a draw of -0.0 included) and
    ``-0.5 einsum(d, Qi, d)`` is ``-0.5 ((d Qi) d)``, bit for bit."""
    rng = np.random.default_rng(7)
    for q in (1.0, 0.37, 12.5):
        Q = np.array([[q]])
        Lq, Qi = np.linalg.cholesky(Q), np.linalg.inv(Q)
        e = rng.standard_normal((6, 33, 1))
        e[0, :3, 0] = [-0.0, 0.0, 1e-310]
        got = e * Lq[0, 0]
        got += 0.0
        assert same(got, e @ Lq.T)
        d = rng.standard_normal((6, 33, 1)) * 5
        t = d[..., 0] * Qi[0, 0]
        t *= d[..., 0]
        t *= -0.5
        assert same(t, -0.5 * np.einsum("...i,ij,...j->...", d, Qi, d))


def test_sbx_fast_form_bit_identical():
    rng = np.random.default_rng(3)
    eps = np.finfo(float).eps
    u = rng.uniform(eps, 1 - eps, (50, 20, 1))
    u[0, :3, 0] = [0.5, eps, 1 - eps]
    p1, p2 = rng.standard_normal((2, 50, 20, 1))
    for eta in (0.0, 2.0, 5.0):
        assert all(same(a, b) for a, b in zip(_sbx(p1, p2, u, eta), sbx_children(p1, p2, u, eta)))


def test_uniform_is_low_plus_span_times_random():
    """The ESPF draws its SBX uniforms as ``random`` scaled: what ``uniform`` computes, draw for draw."""
    eps = np.finfo(float).eps
    for make in (lambda: np.random.default_rng(11), lambda: RunStreams.from_entropy(11, 4)):
        a, b = make(), make()
        want = a.uniform(eps, 1.0 - eps, (4, 500, 1))
        got = b.random((4, 500, 1))
        got *= (1.0 - eps) - eps
        got += eps
        assert same(got, want)
        assert same(a.random((4, 3)), b.random((4, 3)))    # the streams stay in step


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_weight_collapse_path_bit_identical(monkeypatch):
    """A run whose every likelihood underflows (y = 1e200) takes the normalisation's collapse path:
    CMS-PF and ESPF still give the reference's numbers and flags."""
    m = _ning()
    y = m.simulate(12, 4, np.random.default_rng(3)).y.copy()
    y[1, 4:7] = 1e200
    new = CMSParticleFilter(m, 30).filter(y, np.random.default_rng(2))
    old = CMSParticleFilter(m, 30)
    monkeypatch.setattr(old, "_loop", loop_ref.__get__(old))
    monkeypatch.setattr(old.carrier, "generate", old_carrier(old.carrier))
    ref = old.filter(y, np.random.default_rng(2))
    assert new.diagnostics["n_collapsed"] > 0
    assert same(new.x, ref.x) and same(new.diagnostics["collapsed"], ref.diagnostics["collapsed"])
    e_new = EvolutionSamplingParticleFilter(m, 30).filter(y, np.random.default_rng(2))
    e_old = EvolutionSamplingParticleFilter(m, 30)
    monkeypatch.setattr(e_old, "_loop", types.MethodType(espf_loop_reference, e_old))
    e_ref = e_old.filter(y, np.random.default_rng(2))
    assert e_new.diagnostics["n_collapsed"] > 0
    assert same(e_new.x, e_ref.x) and same(e_new.diagnostics["collapsed"], e_ref.diagnostics["collapsed"])
