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

from pfrepro.filters.imm import (IMMParticleFilter, IMMPFOR, _counts_from_below, _indices_from_below,
                                 _indices_from_counts, _put_rows, _systematic_below, mixing_probabilities,
                                 systematic_indices, unit_ball_volume)
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


class _OldIMMPF(IMMParticleFilter):
    interact = _old_interact

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
    return cls(s, *args, **kw).filter(y, filter_streams(seed, "cost", RUNS))


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


def test_replacement_is_its_first_implementation_on_random_sets():
    rng = np.random.default_rng(5)
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
    for kw in (dict(), dict(metric="diagonal"), dict(density="weights"), dict(mix_modes=False)):
        new = IMMPFOR(tracking_system(), N, **kw).replacement(x, w, u, M, counts, other, do)
        old = _OldIMMPFOR(tracking_system(), N, **kw).replacement(x, w, u, M, counts, other, do)
        assert np.array_equal(new[0], old[0]) and np.array_equal(new[1], old[1])


@pytest.mark.parametrize("kw", [dict(), dict(ess_threshold=0.5), dict(resampling="residual", ess_threshold=0.8)])
def test_jmpf_is_its_first_implementation_bit_for_bit(scenario, kw):
    s, y = scenario
    assert_same(run(JumpMarkovParticleFilter, s, y, 3, 400, **kw), run(_OldJMPF, s, y, 3, 400, **kw))
