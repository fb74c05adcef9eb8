"""The IMM-scenario particle filters and their cost work: the same numbers, bit for bit.

The jump-Markov PF was made cheaper by moving data differently (rows gathered and scattered as
opaque records, no (runs, N, r) gather in the mode draw, no gather or scatter of the runs when
every run resamples); the arithmetic is the same, in the same order. The first implementations
of its move step and of the resampling of :mod:`pfrepro.filters.smc_steps` are kept here,
verbatim, as private references, and every output of the filter (estimates and diagnostics) is
held to theirs with ``np.array_equal`` on the IMM chapter's tracking models. IMMPF and IMMPFOR
(Zhou et al. 2017) are held the same way to their present implementation (interaction,
resampling and IMMPFOR's replacement, eqs 6-7, 19, 22-25, kept here verbatim), in every reading
of IMMPFOR and with partial resampling, so that a later rewrite of their data movement has to
keep their numbers.
"""
import math

import numpy as np
import pytest

from pfrepro.filters.base import gaussian_loglik
from pfrepro.filters.imm import (IMMParticleFilter, IMMPFOR, _counts_from_below, _indices_from_below,
                                 _indices_from_counts, _put_rows, _subtract_rows, _systematic_below, _var_axis1,
                                 _Work, mixing_probabilities, systematic_indices, unit_ball_volume)
from pfrepro.filters.jump_markov_pf import JumpMarkovParticleFilter, noise_rows
from pfrepro.filters.smc_steps import repeat_rows
from pfrepro.montecarlo import filter_streams, truth_streams
from pfrepro.rng import take_runs

from conftest import tracking_system


# -- the first implementations (verbatim but for the names) -------------------------------------------
def _old_interact(self, x, w, mu, rng):
    runs, r, N, n = x.shape
    _, M = mixing_probabilities(mu, self.system.Pi)
    W = np.swapaxes(M, 1, 2)[..., None] * w[:, None, :, :]
    u = rng.random((runs, r))
    base = np.repeat(np.arange(runs) * (r * N), r)
    idx = systematic_indices(W.reshape(runs, r, r * N), u, N, overwrite=True, base=base)
    return np.take(x.reshape(-1, n), idx, axis=0), M


def _old_var_axis1(a):
    R, K, n = a.shape
    if R == 1:
        return np.var(a, axis=1)
    t = np.array(np.swapaxes(a, 0, 1), order="C").reshape(K, R * n)
    mean = np.add.reduce(t, axis=0, keepdims=True)
    mean /= K
    np.subtract(t, mean, out=t)
    np.multiply(t, t, out=t)
    out = np.add.reduce(t, axis=0)
    out /= K
    return out.reshape(R, n)


def _old_model_log_likelihood(self, eps, logw, loglik):
    N = eps.shape[-2]
    if self.model_likelihood == "mean":
        a = loglik + (-np.log(N)) if logw is None else logw + loglik
        m = np.max(a, axis=-1, keepdims=True)
        m = np.where(np.isfinite(m), m, 0.0)
        with np.errstate(divide="ignore"):
            return (m[..., 0] + np.log(np.sum(np.exp(a - m), axis=-1)))
    if logw is None:
        w = np.full(eps.shape[:-1], 1.0 / N)
        ebar = (w[..., None, :] @ eps)[..., 0, :]
        dw = eps - ebar[..., None, :]
        dw *= math.sqrt(1.0 / N)
    else:
        w = np.exp(logw - logw.max(axis=-1, keepdims=True))
        w /= w.sum(axis=-1, keepdims=True)
        ebar = (w[..., None, :] @ eps)[..., 0, :]
        d = eps - ebar[..., None, :]
        dw = d * np.sqrt(w)[..., None]
    S = self.system.R + np.swapaxes(dw, -1, -2) @ dw
    return gaussian_loglik(ebar, S)


def _old_joint_whitening(x, w, u):
    R_, r, N, n = x.shape
    wj = (u[:, :, None] * w).reshape(R_, r * N)
    wj = wj / wj.sum(axis=1, keepdims=True)
    flat = x.reshape(R_, r * N, n)
    m = (wj[:, None, :] @ flat)[:, 0]
    dev = flat - m[:, None, :]
    C = np.swapaxes(dev * wj[..., None], -1, -2) @ dev
    spread = _old_var_axis1(flat)
    C = C + np.einsum("ai,ij->aij", 1e-6 * spread + 1e-12, np.eye(n))
    L = np.linalg.cholesky(C)
    Linv = np.linalg.inv(L)
    z = dev @ np.swapaxes(Linv, -1, -2)
    return m, L, z.reshape(R_, r, N, n)


class _OldIMMPF(IMMParticleFilter):
    interact = _old_interact
    model_log_likelihood = _old_model_log_likelihood

    def _resample(self, x, w, do, u_next, M_next, rng, k, cost):
        runs, r, N, n = x.shape
        sel = np.flatnonzero(do.any(axis=1))
        if sel.size == 0:
            return x, w, np.zeros((runs, r), dtype=np.intp)
        uu = take_runs(rng, sel).random((sel.size, r))
        a, j = np.nonzero(do)
        if a.size:
            flat = x.reshape(-1, n)
            anc = systematic_indices(w[a, j], uu[np.searchsorted(sel, a), j], N, overwrite=True, base=(a * r + j) * N)
            x[a, j] = np.take(flat, anc, axis=0)
        w = w.copy()
        w[do] = 1.0 / N
        return x, w, np.zeros((runs, r), dtype=np.intp)


class _OldIMMPFOR(IMMPFOR):
    interact = _old_interact
    model_log_likelihood = _old_model_log_likelihood
    joint_whitening = staticmethod(_old_joint_whitening)

    def replacement(self, x, w, u, M, counts, other_slots, do=None, idx=None):
        R_, r, N, n = x.shape
        do = np.ones((R_, r), dtype=bool) if do is None else np.asarray(do, bool)
        M = np.asarray(M, dtype=float)
        m, L, z = self.joint_whitening(x, w, u)
        if self.metric == "diagonal":
            sd = np.sqrt(np.einsum("aii->ai", L @ np.swapaxes(L, -1, -2)))
            Lc = L / sd[:, :, None]
            z = np.einsum("aij,arnj->arni", Lc, z)
            L = np.einsum("ai,ij->aij", sd, np.eye(n))
            logdet = np.sum(np.log(np.einsum("aii->ai", Lc)), axis=1)[:, None, None]
        else:
            Lc, logdet = None, 0.0
        if self.density == "weights":
            wj = u[:, :, None] * w
            with np.errstate(divide="ignore"):
                logp = np.log(wj / wj.sum(axis=(1, 2), keepdims=True))
        else:
            zw = z if Lc is None else np.einsum("aij,arnj->arni", np.linalg.inv(Lc), z)
            logp = -0.5 * np.einsum("arni,arni->arn", zw, zw) - 0.5 * n * np.log(2 * np.pi) - logdet
        logL = math.lgamma(1 + 1 / n) - (np.log(r * N) + logp + np.log(unit_ball_volume(n))) / n
        logstep = np.log(self.d) + logL
        if idx is None:
            idx = _indices_from_counts(counts)
        rowbase = (np.arange(R_)[:, None] * r + np.arange(r)) * N
        src = np.where(do[..., None], idx, np.arange(N)) + rowbase[..., None]
        out = np.take(x.reshape(-1, n), src, axis=0)
        is_disc = counts == 0
        n_disc = is_disc.sum(axis=-1)
        is_dup = np.zeros((R_, r, N), dtype=bool)
        np.equal(idx[..., 1:], idx[..., :-1], out=is_dup[..., 1:])
        is_dup &= do[..., None]
        f = np.flatnonzero(is_dup)
        if f.size == 0:
            return out, n_disc
        is_disc &= do[..., None]
        z_flat = z.reshape(-1, n)
        z_s = np.take(z_flat, np.flatnonzero(is_disc), axis=0)
        row = f // N
        A, J, Sl = row // r, row % r, f % N
        idx_flat = idx.reshape(-1)
        logstep_flat = logstep.reshape(-1)
        other_flat = other_slots.reshape(-1)[f]
        new = np.zeros((f.size, n))
        for i in range(r):
            base = np.take(rowbase[:, i], A)
            slot = np.where(J == i, Sl, other_flat)
            par = np.take(idx_flat, base + slot) + base
            z_a = np.take(z_flat, par, axis=0)
            dv = z_s - z_a
            dist = np.sqrt(np.einsum("ki,ki->k", dv, dv))
            with np.errstate(divide="ignore", over="ignore"):
                lam = np.log(dist, out=dist)
                np.subtract(np.take(logstep_flat, par), lam, out=lam)
                np.minimum(lam, 0.0, out=lam)
                np.exp(lam, out=lam)
            dv *= lam[:, None]
            dv += z_a
            if self.mix_modes:
                dv *= np.take(M.reshape(-1), (A * r + i) * r + J)[:, None]
            else:
                dv *= (J == i)[:, None]
            new += dv
        _put_rows(out.reshape(-1, n), f, np.take(m, A, axis=0) + np.einsum("kij,kj->ki", np.take(L, A, axis=0), new))
        return out, n_disc

    def _resample(self, x, w, do, u_next, M_next, rng, k, cost):
        runs, r, N, n = x.shape
        replaced = np.zeros((runs, r), dtype=np.intp)
        sel = np.flatnonzero(do.any(axis=1))
        if sel.size == 0:
            return x, w, replaced
        rs = take_runs(rng, sel)
        uu = rs.random((sel.size, r))
        other = rs.integers(0, N, size=(sel.size, r, N))
        ws = np.take(w, sel, axis=0)
        below = _systematic_below(ws, uu, N)
        counts = _counts_from_below(below)
        idx = _indices_from_below(below, N)
        dsel = do[sel]
        new, n_disc = self.replacement(np.take(x, sel, axis=0), ws, u_next[sel], M_next[sel], counts, other, dsel, idx=idx)
        cost["density"][sel] += r * N
        x[sel] = new
        replaced[sel] = np.where(dsel, n_disc, 0)
        w = w.copy()
        w[do] = 1.0 / N
        return x, w, replaced


class _OldJMPF(JumpMarkovParticleFilter):
    def _move(self, k, x, logw, yk, rng, state):
        sysm = self.model
        runs, N, n = x.shape
        mode = self._draw_modes(self._cum_Pi[state["mode"]], rng.random((runs, N)))
        z = rng.standard_normal((runs, N, self._roots.shape[-1]))
        flat = mode.ravel().astype(np.int8 if len(sysm.models) < 128 else np.int64)
        order = np.argsort(flat, kind="stable")
        bounds = np.searchsorted(flat[order], np.arange(len(sysm.models) + 1))
        xo, zo = x.reshape(-1, n)[order], z.reshape(-1, z.shape[-1])[order]
        moved = np.empty_like(xo)
        for j, m in enumerate(sysm.models):
            a, b = bounds[j], bounds[j + 1]
            if b > a:
                moved[a:b] = m.f(xo[a:b], k) + noise_rows(zo[a:b], self._roots[j])
        nxt = np.empty_like(x)
        nxt.reshape(-1, n)[order] = moved
        state["mode"], state["carried"] = mode, (mode,)
        return nxt, sysm.log_likelihood(yk, nxt)

    def _after_weight(self, k, w, x, x_hat, state):
        mode = state["mode"]
        state["diag"]["mode_probs"][:, k - 1] = np.stack(
            [np.where(mode == j, w, 0.0).sum(axis=1) for j in range(self.system.r)], axis=-1)

    def _resample(self, do, w, logw, rng, x, state):
        # smc_steps.resample_runs as first written (gather and scatter of the selected runs' rows)
        arrays = (x, *state.get("carried", ()))
        sel = np.flatnonzero(do)
        if sel.size:
            counts = self._counts_of(w[sel], rng if sel.size == len(do) else take_runs(rng, sel))
            for a, new in zip(arrays, repeat_rows(counts, *(a[sel] for a in arrays))):
                a[sel] = new
            logw[sel] = -np.log(w.shape[1])
        return x


# -- the checks ---------------------------------------------------------------------------------------
RUNS, T = 5, 30


@pytest.fixture(scope="module")
def scenario():
    s = tracking_system()
    return s, s.simulate(T, RUNS, truth_streams(11, RUNS)).y


def assert_same(new, old):
    assert np.array_equal(new.x, old.x)
    assert new.diagnostics.keys() == old.diagnostics.keys()
    for key, v in old.diagnostics.items():
        a = new.diagnostics[key]
        if isinstance(v, np.ndarray):
            assert a.dtype == v.dtype and np.array_equal(a, v), key
        else:
            assert a == v, key


def run(cls, s, y, seed, *args, **kw):
    return cls(s, *args, **kw).filter(y, filter_streams(seed, "cost", len(y)))


@pytest.mark.parametrize("kw", [dict(), dict(n_th=1.0), dict(n_th=0.0), dict(model_likelihood="mean", n_th=0.3)])
def test_immpf_is_its_first_implementation_bit_for_bit(scenario, kw):
    s, y = scenario
    assert_same(run(IMMParticleFilter, s, y, 1, 120, keep_steps=(3, 17), **kw),
                run(_OldIMMPF, s, y, 1, 120, keep_steps=(3, 17), **kw))


@pytest.mark.parametrize("kw", [dict(), dict(replace="always"), dict(density="weights"), dict(metric="diagonal"),
                                dict(mix_modes=False), dict(d=0.1, n_th=0.3), dict(d=10.0, n_th=0.9)])
def test_immpfor_is_its_first_implementation_bit_for_bit(scenario, kw):
    s, y = scenario
    assert_same(run(IMMPFOR, s, y, 2, 150, keep_steps=(5,), **kw),
                run(_OldIMMPFOR, s, y, 2, 150, keep_steps=(5,), **kw))


def test_both_resampling_paths_are_exercised(scenario):
    # the comparisons above cover steps where every run resamples (no copy back: the default
    # settings) and steps where only some do (the selected runs' rows put back: n_th = 0.3)
    s, y = scenario
    every = run(IMMPFOR, s, y, 2, 150).diagnostics["resampled"].any(axis=2)
    some = run(IMMPFOR, s, y, 2, 150, d=0.1, n_th=0.3).diagnostics["resampled"].any(axis=2)
    assert every.all(axis=0).any()
    assert (some.any(axis=0) & ~some.all(axis=0)).any()


def _replacement_inputs(seed):
    """Random arguments of ``IMMPFOR.replacement`` (4 runs, 3 modes, N = 40, the 6-D state's scales),
    with a run whose modes do not resample; returns them and N."""
    rng = np.random.default_rng(seed)
    R, r, N, n = 4, 3, 40, 6
    x = rng.normal(size=(R, r, N, n)) * np.array([1e4, 1e2, 1.0, 1e4, 1e2, 1.0])
    w = rng.gamma(0.3, size=(R, r, N))
    w /= w.sum(axis=-1, keepdims=True)
    u = rng.dirichlet(np.ones(r), size=R)
    M = rng.dirichlet(np.ones(r), size=(R, r)).transpose(0, 2, 1)
    counts = _counts_from_below(_systematic_below(w, rng.random((R, r)), N))
    other = rng.integers(0, N, size=(R, r, N))
    do = rng.random((R, r)) < 0.6
    do[1] = False                                      # a run with no mode to resample
    return x, w, u, M, counts, other, do, N


def test_replacement_is_its_first_implementation_on_random_sets():
    x, w, u, M, counts, other, do, N = _replacement_inputs(5)
    for kw in (dict(), dict(metric="diagonal"), dict(density="weights"), dict(mix_modes=False)):
        new = IMMPFOR(tracking_system(), N, **kw).replacement(x, w, u, M, counts, other, do)
        old = _OldIMMPFOR(tracking_system(), N, **kw).replacement(x, w, u, M, counts, other, do)
        assert np.array_equal(new[0], old[0]) and np.array_equal(new[1], old[1])


@pytest.mark.parametrize("kw", [dict(), dict(ess_threshold=0.5), dict(resampling="residual", ess_threshold=0.8)])
def test_jmpf_is_its_first_implementation_bit_for_bit(scenario, kw):
    s, y = scenario
    assert_same(run(JumpMarkovParticleFilter, s, y, 3, 400, **kw), run(_OldJMPF, s, y, 3, 400, **kw))


# -- the work-memory rewrite of IMMPF/IMMPFOR (work arrays reused across steps, sets replaced in place) --
#: every reading and option of IMMPFOR the chapter runs (the d grid's ends, the three readings of the
#: lost equations, the model-likelihood reading, the own-parent ablation, N_th = N)
CHAPTER_READINGS = [dict(), dict(d=1e-6), dict(d=3.0), dict(replace="always"), dict(density="weights"),
                    dict(metric="diagonal"), dict(model_likelihood="mean"), dict(mix_modes=False, d=0.1),
                    dict(n_th=1.0)]


@pytest.fixture(scope="module")
def scenario8():
    s = tracking_system()
    return s, s.simulate(T, 8, truth_streams(12, 8)).y


@pytest.mark.parametrize("runs", [1, 3, 8])
@pytest.mark.parametrize("kw", CHAPTER_READINGS)
def test_immpfor_every_chapter_reading_and_batch_size_is_its_first_implementation(scenario8, runs, kw):
    s, y = scenario8
    assert_same(run(IMMPFOR, s, y[:runs], 4, 120, keep_steps=(2, 9), **kw),
                run(_OldIMMPFOR, s, y[:runs], 4, 120, keep_steps=(2, 9), **kw))


@pytest.mark.parametrize("runs", [1, 3, 8])
@pytest.mark.parametrize("kw", [dict(), dict(model_likelihood="mean"), dict(n_th=1.0)])
def test_immpf_every_batch_size_is_its_first_implementation(scenario8, runs, kw):
    s, y = scenario8
    assert_same(run(IMMParticleFilter, s, y[:runs], 5, 120, keep_steps=(4,), **kw),
                run(_OldIMMPF, s, y[:runs], 5, 120, keep_steps=(4,), **kw))


def test_joint_whitening_with_work_memory_is_the_first_one():
    rng = np.random.default_rng(8)
    for R in (1, 3, 8):
        x = rng.normal(size=(R, 3, 70, 6)) * np.array([1e4, 1e2, 1.0, 1e4, 1e2, 1.0])
        w = rng.gamma(0.5, size=(R, 3, 70))
        u = rng.dirichlet(np.ones(3), size=R)
        work = _Work()
        for got in (IMMPFOR.joint_whitening(x, w, u), IMMPFOR.joint_whitening(x, w, u, work),
                    IMMPFOR.joint_whitening(x, w, u, work)):                   # work memory reused
            for a, b in zip(got, _old_joint_whitening(x, w, u)):
                assert np.array_equal(a, b)
        assert np.array_equal(_var_axis1(x.reshape(R, -1, 6), work), _old_var_axis1(x.reshape(R, -1, 6)))


def test_subtract_rows_is_the_broadcast_subtraction():
    rng = np.random.default_rng(9)
    for shape in ((4, 1500, 6), (2, 3, 500, 2), (5, 97, 3), (1, 1, 4), (3, 128, 6)):
        a = rng.normal(size=shape) * 1e3
        v = rng.normal(size=shape[:-2] + shape[-1:])
        assert np.array_equal(_subtract_rows(a, v), a - v[..., None, :])
    a = rng.normal(size=(6, 40, 3))[::2]                                        # not contiguous
    v = rng.normal(size=(3, 3))
    assert np.array_equal(_subtract_rows(a, v), a - v[..., None, :])


def test_replacement_in_place_is_the_replacement_into_a_new_array():
    x, w, u, M, counts, other, do, N = _replacement_inputs(6)
    for kw in (dict(), dict(metric="diagonal"), dict(density="weights"), dict(mix_modes=False)):
        f = IMMPFOR(tracking_system(), N, **kw)
        new, nd = f.replacement(x, w, u, M, counts, other, do)
        xi = x.copy()
        got, nd2 = f.replacement(xi, w, u, M, counts, other, do, out=xi)
        assert got is xi and np.array_equal(got, new) and np.array_equal(nd, nd2)
        assert np.array_equal(got[~do], x[~do])                               # modes not in do untouched


def test_one_filter_object_in_two_threads_at_once(scenario8):
    # each thread's filter call has its own work memory: the same object run concurrently gives each
    # call's serial result, and no work memory is left behind
    from concurrent.futures import ThreadPoolExecutor

    from pfrepro.filters import imm as imm_module
    s, y = scenario8
    f = IMMPFOR(s, 150, n_th=0.8)
    serial = [f.filter(y[i:i + 4], filter_streams(7 + i, "cost", 4)) for i in (0, 4)]
    with ThreadPoolExecutor(2) as ex:
        par = list(ex.map(lambda i: f.filter(y[i:i + 4], filter_streams(7 + i, "cost", 4)), (0, 4)))
    for a, b in zip(par, serial):
        assert_same(a, b)
    assert f._work is None and not getattr(imm_module._THREAD, "works", {})


def test_work_memory_kept_for_the_next_call_up_to_the_cap(scenario8, monkeypatch):
    from pfrepro.filters import imm as imm_module
    s, y = scenario8
    f = IMMPFOR(s, 100)
    first = f.filter(y[:3], filter_streams(3, "cost", 3))
    kept = imm_module._THREAD.kept
    assert 0 < kept.nbytes <= imm_module.KEEP_WORK_BYTES
    assert_same(IMMPFOR(s, 100).filter(y[:3], filter_streams(3, "cost", 3)), first)   # on the kept memory
    assert imm_module._THREAD.kept is kept
    monkeypatch.setattr(imm_module, "KEEP_WORK_BYTES", 1000)
    f.filter(y[:3], filter_streams(3, "cost", 3))
    assert getattr(imm_module._THREAD, "kept", None) is None                  # over the cap: freed


def test_replacement_out_must_be_a_c_contiguous_array_like_x():
    rng = np.random.default_rng(2)
    x = rng.normal(size=(2, 3, 10, 6))
    w = np.full((2, 3, 10), 0.1)
    u = np.full((2, 3), 1 / 3)
    M = np.full((2, 3, 3), 1 / 3)
    counts = np.ones((2, 3, 10), dtype=np.intp)
    f = IMMPFOR(tracking_system(), 10)
    for bad in (np.empty((2, 3, 10, 6), order="F"), np.empty((2, 3, 10, 5)), np.empty((2, 3, 10, 6), np.float32)):
        with pytest.raises(ValueError, match="out must be"):
            f.replacement(x, w, u, M, counts, np.zeros((2, 3, 10), dtype=np.intp), out=bad)
