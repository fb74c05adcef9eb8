"""IMM filters: IMMPF and IMMPFOR (Zhou et al. 2017, reconstructed) and the Kalman IMM.

Every inner step is pinned by a hand-computed case or an invariant: mixing probabilities
(eq 6), the interaction draw (eq 7), model likelihoods in both readings (eqs 11-15),
model probabilities (eq 16), resampling (eq 19) and IMMPFOR's replacement (eqs 22-25).
"""

import numpy as np
import pytest
from scipy.spatial import cKDTree
from scipy.special import gamma as G
from scipy.stats import norm

from pfrepro.filters import BootstrapParticleFilter, KalmanFilter
from pfrepro.filters.imm import (IMMKalman, IMMParticleFilter, IMMPFOR, _indices_from_counts, _var_axis1,
                                 systematic_indices,
                                 mixing_probabilities, nn_distance_scale, systematic_counts, unit_ball_volume)
from pfrepro.filters.resampling import resample_counts
from pfrepro.models import LinearGaussianModel
from pfrepro.models.jump_markov import JumpMarkovSystem
from pfrepro.models.tracking import cv_model
from pfrepro.rng import RunStreams

from conftest import TRACK_MEAS as MEAS, TRACK_P0 as P0, TRACK_X0 as X0, tracking_system


def scalar_system(Pi=((0.95, 0.05), (0.1, 0.9)), R=1.0):
    """Two linear-Gaussian scalar modes: slow and fast random walk with drift."""
    m1 = LinearGaussianModel([[1.0]], [[1.0]], [[0.1]], [[R]], x0=[0.0], m0=[0.0], P0=[[1.0]])
    m2 = LinearGaussianModel([[0.8]], [[1.0]], [[4.0]], [[R]], x0=[0.0], m0=[0.0], P0=[[1.0]])
    return JumpMarkovSystem([m1, m2], np.array(Pi))


# -- eq 6 and eq 16 --------------------------------------------------------------------------------
def test_mixing_probabilities_hand():
    mu = np.array([0.2, 0.8])
    Pi = np.array([[0.9, 0.1], [0.3, 0.7]])          # row = from
    c, M = mixing_probabilities(mu, Pi)
    assert np.allclose(c, [0.42, 0.58])
    assert np.allclose(M, [[0.18 / 0.42, 0.02 / 0.58], [0.24 / 0.42, 0.56 / 0.58]])
    assert np.allclose(M.sum(axis=0), 1.0)           # each column mu_{.|j} is a distribution


def test_mode_probability_update_hand():
    u = IMMParticleFilter.update_mode_probabilities(np.array([[0.42, 0.58]]), np.log([[2.0, 1.0]]))
    assert np.allclose(u, [[0.84 / 1.42, 0.58 / 1.42]])
    # every model likelihood underflowed in run 1: the predicted probabilities are kept
    u = IMMParticleFilter.update_mode_probabilities(np.array([[0.42, 0.58], [0.3, 0.7]]),
                                                    np.array([[np.log(2.0), 0.0], [-np.inf, -np.inf]]))
    assert np.allclose(u, [[0.84 / 1.42, 0.58 / 1.42], [0.3, 0.7]])


# -- eq 7 ----------------------------------------------------------------------------------------------
def test_systematic_counts_hand_and_bit_identity():
    assert systematic_counts(np.array([0.5, 0.25, 0.25]), np.array(0.5), 4).tolist() == [2, 1, 1]
    assert systematic_counts(np.array([0.1, 0.9]), np.array(0.5), 3).tolist() == [0, 3]
    w = np.random.default_rng(0).random((4, 50))
    u = np.random.default_rng(1).random((4, 1))
    ref = resample_counts(w, np.random.default_rng(1))
    assert np.array_equal(systematic_counts(w, u[:, 0], 50), ref)


def test_systematic_indices_equal_repeat_of_counts():
    """The bincount construction of the ancestors equals np.repeat(arange, counts), row by row,
    for sparse weights (many zero counts), n_out < M and n_out > M; it never mutates W unless asked."""
    rng = np.random.default_rng(5)
    for shape, n_out in (((3, 2, 40), 40), ((4, 3, 60), 20), ((2, 7), 30), ((5,), 5)):
        W = rng.random(shape) ** 6 * (rng.random(shape) < 0.5)
        W[..., 0] += 1e-3
        u = rng.random(shape[:-1])
        counts = systematic_counts(W, u, n_out)
        rows = counts.reshape(-1, shape[-1])
        ref = np.stack([np.repeat(np.arange(shape[-1]), c) for c in rows]).reshape(shape[:-1] + (n_out,))
        W0 = W.copy()
        assert np.array_equal(systematic_indices(W, u, n_out), ref)
        assert np.array_equal(W, W0)
        assert np.array_equal(_indices_from_counts(counts), ref)
        assert np.array_equal(systematic_indices(W.copy(), u, n_out, overwrite=True), ref)
    assert systematic_indices(np.array([0.5, 0.25, 0.25]), np.array(0.5), 4).tolist() == [0, 0, 1, 2]
    # u = 0 (the clipped case): still n_out sorted ancestors in range, every atom of weight 1/3 thrice
    idx0 = systematic_indices(np.full((2, 3), 1 / 3), np.zeros(2), 9)
    assert idx0.tolist() == [[0, 0, 0, 1, 1, 1, 2, 2, 2]] * 2
    with pytest.raises(ValueError, match="non-negative"):
        _indices_from_counts(np.array([[2, -1, 3]]))


def test_var_axis1_is_numpy_var_bit_for_bit():
    """The transposed variance used by IMMPFOR's whitening is np.var(a, axis=1) exactly."""
    for R, K, n in ((1, 50, 6), (2, 600, 6), (7, 1500, 6), (3, 7, 2), (4, 1, 3)):
        a = np.random.default_rng(R * K).normal(size=(R, K, n)) * 1e4 + 3e4
        a0 = a.copy()
        assert np.array_equal(_var_axis1(a), np.var(a, axis=1))
        assert np.array_equal(a, a0)
        assert np.array_equal(_var_axis1(a)[-1], _var_axis1(a[-1:])[0])      # run i's spread: any batch


def test_interaction_hand_swap():
    """Pi = [[0, 1], [1, 0]]: mode 0 takes all its particles from mode 1 and vice versa."""
    f = IMMParticleFilter(scalar_system(Pi=((0.0, 1.0), (1.0, 0.0))), 4)
    x = np.array([[[[1.0], [2.0], [3.0], [4.0]], [[10.0], [20.0], [30.0], [40.0]]]])
    w = np.array([[[0.25] * 4, [0.0, 0.0, 0.5, 0.5]]])
    new, M = f.interact(x, w, np.array([[0.5, 0.5]]), np.random.default_rng(0))
    assert np.allclose(M[0], [[0, 1], [1, 0]])
    assert sorted(new[0, 0, :, 0]) == [30, 30, 40, 40]
    assert sorted(new[0, 1, :, 0]) == [1, 2, 3, 4]


def test_interaction_proportions():
    """Target j takes (within one particle) N mu_{i|j} particles from source i."""
    f = IMMParticleFilter(scalar_system(), 1000)
    runs, N = 3, 1000
    x = np.zeros((runs, 2, N, 1))
    x[:, 1] = 1.0                                     # mark the source mode
    w = np.full((runs, 2, N), 1.0 / N)
    mu = np.array([[0.3, 0.7]] * runs)
    new, M = f.interact(x, w, mu, RunStreams.from_entropy(0, runs))
    frac_from_1 = new[..., 0].mean(axis=-1)           # (runs, r_target)
    assert np.all(np.abs(frac_from_1 - M[:, 1, :]) <= 1.0 / N + 1e-12)


# -- eqs 11-15 -------------------------------------------------------------------------------------------
def test_model_likelihood_hand_both_readings():
    sysm = scalar_system(R=1.0)
    eps = np.array([1.0, 2.0, 4.0]).reshape(1, 1, 3, 1)
    logw = np.log(np.full((1, 1, 3), 1 / 3))
    ll = norm.logpdf(eps[..., 0], scale=1.0)
    g = IMMParticleFilter(sysm, 3, model_likelihood="gaussian").model_log_likelihood(eps, logw, ll)
    S = 1.0 + 42 / 27                                  # R + mean squared deviation from 7/3
    assert np.allclose(g, norm.logpdf(7 / 3, scale=np.sqrt(S)))
    m = IMMParticleFilter(sysm, 3, model_likelihood="mean").model_log_likelihood(eps, logw, ll)
    assert np.allclose(m, np.log(np.mean(norm.pdf([1.0, 2.0, 4.0]))))
    # non-uniform previous weights enter both readings
    w = np.array([0.5, 0.3, 0.2])
    g2 = IMMParticleFilter(sysm, 3).model_log_likelihood(eps, np.log(w)[None, None], ll)
    eb = w @ [1, 2, 4]
    assert np.allclose(g2, norm.logpdf(eb, scale=np.sqrt(1 + w @ (np.array([1, 2, 4]) - eb) ** 2)))
    m2 = IMMParticleFilter(sysm, 3, model_likelihood="mean").model_log_likelihood(eps, np.log(w)[None, None], ll)
    assert np.allclose(m2, np.log(w @ norm.pdf([1.0, 2.0, 4.0])))


def test_particle_log_likelihood_is_the_gaussian_density():
    f = IMMParticleFilter(tracking_system(), 3)
    eps = np.random.default_rng(0).normal(size=(2, 3, 4, 3)) * [100.0, 5.0, 0.01]
    from scipy.stats import multivariate_normal
    ref = multivariate_normal(np.zeros(3), f.system.R).logpdf(eps)
    assert np.allclose(f.particle_log_likelihood(eps), ref, rtol=1e-12)


# -- eq 19 --------------------------------------------------------------------------------------------------
def test_resampled_modes_carry_equal_weights_others_untouched():
    f = IMMParticleFilter(scalar_system(), 5)
    rng = np.random.default_rng(0)
    x = rng.normal(size=(2, 2, 5, 1))
    w = rng.random((2, 2, 5)); w /= w.sum(-1, keepdims=True)
    do = np.array([[True, False], [False, False]])
    x2, w2, _ = f._resample(x.copy(), w, do, None, None, RunStreams.from_entropy(0, 2), 1, None)
    assert np.all(w2[0, 0] == 0.2) and np.array_equal(w2[~do], w[~do]) and np.array_equal(x2[1], x[1])
    assert set(x2[0, 0, :, 0]) <= set(x[0, 0, :, 0]) and np.array_equal(x2[0, 1], x[0, 1])


# -- whole filter -------------------------------------------------------------------------------------------
def test_one_mode_immpf_is_the_bootstrap_pf():
    m = cv_model(1.0, 1.0, MEAS, X0, P0=P0)
    sim = m.simulate(15, 3, RunStreams.from_entropy(1, 3))
    pf = BootstrapParticleFilter(m, 200, resampling="systematic").filter(sim.y, RunStreams.from_entropy(9, 3))
    imm = IMMParticleFilter(JumpMarkovSystem([m], [[1.0]]), 200, n_th=0.0).filter(sim.y, RunStreams.from_entropy(9, 3))
    assert np.allclose(imm.x, pf.x, rtol=1e-12, atol=1e-8)
    assert np.all(imm.diagnostics["mode_probs"] == 1.0)


@pytest.mark.parametrize("cls, lik", [(IMMParticleFilter, "gaussian"), (IMMParticleFilter, "mean"),
                                      (IMMPFOR, "gaussian"), (IMMPFOR, "mean")])
def test_batch_invariance(cls, lik):
    sysm = tracking_system()
    sim = sysm.simulate(12, 8, RunStreams.from_entropy(4, 8))
    f = cls(sysm, 60, model_likelihood=lik, n_th=0.9)
    full = f.filter(sim.y, RunStreams.from_entropy(5, 8))
    one = f.filter(sim.y[3:4], RunStreams.from_entropy(5, 1, start=3))
    assert np.array_equal(full.x[3], one.x[0])
    assert np.array_equal(full.diagnostics["mode_probs"][3], one.diagnostics["mode_probs"][0])
    assert full.diagnostics["resampled"].any()


def test_immpf_approaches_imm_kf_with_many_particles():
    """Linear-Gaussian modes: the IMMPF (mean reading) with many particles tracks the IMM-KF."""
    sysm = scalar_system()
    sim = sysm.simulate(25, 2, RunStreams.from_entropy(11, 2))
    kf = IMMKalman(sysm, [KalmanFilter(m) for m in sysm.models]).filter(sim.y)
    pf = IMMParticleFilter(sysm, 20000, model_likelihood="mean", n_th=0.0).filter(sim.y, RunStreams.from_entropy(12, 2))
    sd = np.sqrt(kf.P[..., 0, 0])
    assert np.max(np.abs(pf.x[..., 0] - kf.x[..., 0]) / sd) < 0.15
    assert np.max(np.abs(pf.diagnostics["mode_probs"] - kf.diagnostics["mode_probs"])) < 0.06


def test_imm_kalman_against_filterpy():
    filterpy = pytest.importorskip("filterpy")
    from filterpy.kalman import IMMEstimator, KalmanFilter as FKF

    F1 = np.array([[1.0, 1.0], [0.0, 1.0]]); F2 = np.array([[1.0, 1.0], [0.0, 0.5]])
    H = np.array([[1.0, 0.0]])
    Q1 = np.diag([0.01, 0.01]); Q2 = np.diag([0.5, 2.0]); R = np.array([[2.0]])
    Pi = np.array([[0.97, 0.03], [0.2, 0.8]])          # asymmetric: catches a transposed convention
    P0_ = np.diag([4.0, 1.0]); x0 = np.array([0.0, 1.0])
    ms = [LinearGaussianModel(F, H, Q, R, x0=x0, P0=P0_) for F, Q in ((F1, Q1), (F2, Q2))]
    sysm = JumpMarkovSystem(ms, Pi, initial_probs=[0.6, 0.4])
    sim = sysm.simulate(30, 1, np.random.default_rng(3))
    ours = IMMKalman(sysm, [KalmanFilter(m) for m in ms]).filter(sim.y)
    fs = []
    for F, Q in ((F1, Q1), (F2, Q2)):
        f = FKF(dim_x=2, dim_z=1); f.F, f.H, f.Q, f.R, f.x, f.P = F, H, Q, R, x0.copy(), P0_.copy()
        fs.append(f)
    imm = IMMEstimator(fs, np.array([0.6, 0.4]), Pi)
    for k in range(30):
        imm.predict(); imm.update(sim.y[0, k])
        assert np.allclose(ours.x[0, k], imm.x, rtol=1e-8, atol=1e-8)
        assert np.allclose(ours.P[0, k], imm.P, rtol=1e-7, atol=1e-8)
        assert np.allclose(ours.diagnostics["mode_probs"][0, k], imm.mu, rtol=1e-8, atol=1e-10)


# -- Theorem 1 and IMMPFOR (eqs 22-25) -----------------------------------------------------------------------
def test_unit_ball_and_theorem1():
    assert np.isclose(unit_ball_volume(1), 2) and np.isclose(unit_ball_volume(2), np.pi)
    assert np.isclose(unit_ball_volume(3), 4 * np.pi / 3)
    # d = 1, uniform density 1: Gamma(2) / (2 N) = 1 / (2N)
    assert np.isclose(nn_distance_scale(100, 1.0, 1), 1 / 200)
    rng = np.random.default_rng(0)
    for d in (1, 2):
        N = 20000
        pts = rng.random((N, d))
        dist, _ = cKDTree(pts).query(pts, k=2)
        inner = np.all((pts > 0.05) & (pts < 0.95), axis=1)      # away from the boundary
        assert np.isclose(dist[inner, 1].mean(), nn_distance_scale(N, 1.0, d), rtol=0.03)
    assert np.isclose(nn_distance_scale(N, 1.0, 2), G(1.5) / np.sqrt(N * np.pi))


def test_joint_whitening_degenerate_weights_stay_finite():
    rng = np.random.default_rng(3)
    x = rng.normal(size=(1, 2, 10, 3))
    w = np.zeros((1, 2, 10)); w[0, :, 4] = 1.0                 # all weight on one particle per mode
    x[0, 1, 4] = x[0, 0, 4]                                     # ... and the same state
    m, L, z = IMMPFOR.joint_whitening(x, w, np.array([[0.5, 0.5]]))
    assert np.all(np.isfinite(z)) and np.all(np.isfinite(L))
    counts = np.zeros((1, 2, 10), dtype=np.intp); counts[0, :, 4] = 10
    new, nd = IMMPFOR(scalar_system(), 10).replacement(x, w, np.array([[0.5, 0.5]]), np.full((1, 2, 2), 0.5),
                                                        counts, rng.integers(0, 10, size=(1, 2, 10)))
    assert np.all(np.isfinite(new)) and np.all(nd == 9)


def test_joint_whitening_moments():
    rng = np.random.default_rng(2)
    x = rng.normal(size=(2, 3, 40, 4)) * [1, 10, 100, 0.1]
    w = rng.random((2, 3, 40)); w /= w.sum(-1, keepdims=True)
    u = np.array([[0.2, 0.3, 0.5], [0.6, 0.3, 0.1]])
    m, L, z = IMMPFOR.joint_whitening(x, w, u)
    wj = (u[:, :, None] * w).reshape(2, -1)
    zf = z.reshape(2, -1, 4)
    assert np.allclose(np.einsum("al,ali->ai", wj, zf), 0, atol=1e-9)
    C = np.einsum("al,ali,alj->aij", wj, zf, zf)
    assert np.allclose(C, np.eye(4), atol=1e-4)


def _reference_replacement(f, x, w, u, M, counts, other):
    """Loop version of eqs 22-25 written from the IMMPFOR docstring (independent of the vectorised code)."""
    R_, r, N, n = x.shape
    out = np.empty_like(x)
    for a in range(R_):
        wj = (u[a][:, None] * w[a]).ravel(); wj /= wj.sum()
        flat = x[a].reshape(-1, n)
        mean = wj @ flat
        C = (flat - mean).T @ ((flat - mean) * wj[:, None])
        C += np.diag(1e-6 * flat.var(axis=0) + 1e-12)
        L = np.linalg.cholesky(C)
        z = np.linalg.solve(L, (x[a] - mean).reshape(-1, n).T).T.reshape(r, N, n)
        p = np.exp(-0.5 * (z ** 2).sum(-1)) / (2 * np.pi) ** (n / 2)
        step = f.d * G(1 + 1 / n) / (r * N * p * unit_ball_volume(n)) ** (1 / n)
        for j in range(r):
            anc = np.repeat(np.arange(N), counts[a, j])
            discarded = [l for l in range(N) if counts[a, j, l] == 0]
            out[a, j] = x[a, j, anc]
            m_ = 0
            for s in range(1, N):
                if anc[s] != anc[s - 1]:
                    continue
                zs = z[j, discarded[m_]]; m_ += 1
                znew = np.zeros(n)
                for i in range(r):
                    anc_i = np.repeat(np.arange(N), counts[a, i])
                    l_a = anc_i[s] if i == j else anc_i[other[a, j, s]]
                    za = z[i, l_a]
                    dist = np.linalg.norm(zs - za)
                    lam = min(1.0, step[i, l_a] / dist) if dist > 0 else 0.0
                    znew += M[a, i, j] * (za + lam * (zs - za))
                out[a, j, s] = mean + L @ znew
    return out


def test_replacement_matches_hand_loop_and_invariants():
    rng = np.random.default_rng(5)
    R_, r, N, n = 2, 3, 7, 2
    f = IMMPFOR(scalar_system(), N, d=0.8)
    x = rng.normal(size=(R_, r, N, n)) * [3.0, 0.5]
    w = rng.random((R_, r, N)) ** 4; w /= w.sum(-1, keepdims=True)
    u = rng.dirichlet(np.ones(r), size=R_)
    M = rng.dirichlet(np.ones(r), size=(R_, r)).transpose(0, 2, 1)     # columns sum to 1
    counts = systematic_counts(w, rng.random((R_, r)), N)
    other = rng.integers(0, N, size=(R_, r, N))
    new, n_disc = f.replacement(x, w, u, M, counts, other)
    assert np.allclose(new, _reference_replacement(f, x, w, u, M, counts, other), rtol=1e-10, atol=1e-10)
    assert np.array_equal(n_disc, (counts == 0).sum(-1))
    # slots that are first copies keep the resampled particle
    idx = _indices_from_counts(counts)
    first = np.ones(idx.shape, bool); first[..., 1:] = idx[..., 1:] != idx[..., :-1]
    res = np.take_along_axis(x, idx[..., None], axis=2)
    assert np.array_equal(new[first], res[first])
    # a subset of modes: those rows exactly as with all modes, the others untouched; idx passed in = computed
    do = np.array([[True, False, True], [False, True, False]])
    part, _ = f.replacement(x, w, u, M, counts, other, do)
    assert np.array_equal(part[do], new[do]) and np.array_equal(part[~do], x[~do])
    assert np.array_equal(f.replacement(x, w, u, M, counts, other, do, idx=idx)[0], part)


def test_replacement_limits():
    """M = I: d -> 0 gives plain resampling (copies); d -> inf puts each new particle on its x_s."""
    rng = np.random.default_rng(6)
    R_, r, N, n = 1, 2, 6, 3
    x = rng.normal(size=(R_, r, N, n))
    w = rng.random((R_, r, N)) ** 3; w /= w.sum(-1, keepdims=True)
    u = np.array([[0.5, 0.5]]); M = np.eye(r)[None]
    counts = systematic_counts(w, np.array([[0.3, 0.6]]), N)
    other = rng.integers(0, N, size=(R_, r, N))
    idx = _indices_from_counts(counts)
    res = np.take_along_axis(x, idx[..., None], axis=2)
    tiny, _ = IMMPFOR(scalar_system(), N, d=1e-12).replacement(x, w, u, M, counts, other)
    assert np.allclose(tiny, res, atol=1e-9)
    huge, _ = IMMPFOR(scalar_system(), N, d=1e12).replacement(x, w, u, M, counts, other)
    for j in range(r):
        disc = np.flatnonzero(counts[0, j] == 0)
        dup = np.flatnonzero(np.r_[False, idx[0, j, 1:] == idx[0, j, :-1]])
        assert np.allclose(huge[0, j, dup], x[0, j, disc], atol=1e-8)


def test_immpfor_counts_and_no_extra_likelihoods():
    sysm = tracking_system()
    sim = sysm.simulate(10, 2, RunStreams.from_entropy(4, 2))
    a = IMMPFOR(sysm, 50, n_th=1.0).filter(sim.y, RunStreams.from_entropy(5, 2))
    b = IMMParticleFilter(sysm, 50, n_th=1.0).filter(sim.y, RunStreams.from_entropy(5, 2))
    assert np.array_equal(a.diagnostics["likelihood_evals"], b.diagnostics["likelihood_evals"])
    assert np.all(a.diagnostics["likelihood_evals"] == 10 * 3 * 50)
    assert np.all(a.diagnostics["density_evals"] == a.diagnostics["resampled"].any(-1).sum(-1) * 3 * 50)
    assert np.all(b.diagnostics["density_evals"] == 0) and a.diagnostics["replaced"].sum() > 0


# -- bad inputs ------------------------------------------------------------------------------------------
def test_bad_inputs_refused():
    sysm = tracking_system()
    with pytest.raises(ValueError, match="n_particles"):
        IMMParticleFilter(sysm, 0)
    with pytest.raises(TypeError, match="n_particles"):
        IMMPFOR(sysm, 2.5)
    with pytest.raises(ValueError, match="model_likelihood"):
        IMMParticleFilter(sysm, 10, model_likelihood="max")
    with pytest.raises(ValueError, match="n_th"):
        IMMParticleFilter(sysm, 10, n_th=1.5)
    with pytest.raises(ValueError, match="step coefficient"):
        IMMPFOR(sysm, 10, d=0.0)
    with pytest.raises(ValueError, match="one filter per mode"):
        IMMKalman(sysm, [])
    with pytest.raises(TypeError, match="rng"):
        IMMParticleFilter(sysm, 10).filter(np.zeros((1, 3, 3)), rng=1)
    with pytest.raises(ValueError, match="NaN"):
        IMMParticleFilter(sysm, 10).filter(np.full((1, 3, 3), np.nan), np.random.default_rng(0))


def test_experiment_runner_chunks_are_bit_identical():
    from concurrent.futures import ThreadPoolExecutor

    from pfrepro.experiments import immpfor_zhou2017 as E
    sc = E.scenario(duration=20, left_turn=(5, 8), right_turn=(12, 15))
    b = {"IMMPF": ("immpf", {"N": 20}), "IMMPFOR": ("immpfor", {"N": 20}), "IMM-EKF": ("imm_ekf", {})}
    serial = E.run(b, sc, runs=3, seed=1)
    with ThreadPoolExecutor(2) as ex:
        par = E.run(b, sc, runs=3, seed=1, executor=ex, chunks=2)
    assert np.array_equal(serial.sim.y, par.sim.y)
    for n in b:
        assert np.array_equal(serial.results[n].x, par.results[n].x)
    assert np.array_equal(serial.results["IMMPFOR"].diagnostics["density_evals"],
                          par.results["IMMPFOR"].diagnostics["density_evals"])
    # the truth follows the schedule: CV outside the turns, constant speed in the turns (q small)
    assert np.array_equal(serial.sim.modes[0], E.schedule(sc))


def test_immpfor_replacement_gets_updated_probabilities(monkeypatch):
    """Step 7 uses u(k) and mu_{i|j}(k|k) (eq 6 with the updated u), not those of step k-1."""
    sysm = tracking_system()
    sim = sysm.simulate(6, 2, RunStreams.from_entropy(4, 2))
    f = IMMPFOR(sysm, 40, n_th=1.0)
    calls = []
    orig = IMMPFOR.replacement

    def spy(self, x, w, u, M, counts, other, do=None, **kw):
        calls.append((u.copy(), M.copy()))
        return orig(self, x, w, u, M, counts, other, do, **kw)

    monkeypatch.setattr(IMMPFOR, "replacement", spy)
    res = f.filter(sim.y, RunStreams.from_entropy(5, 2))
    assert len(calls) == 6
    for k, (u, M) in enumerate(calls):
        up = res.diagnostics["mode_probs"][:, k]
        assert np.allclose(u, up)
        assert np.allclose(M, mixing_probabilities(up, sysm.Pi)[1])


def test_ess_and_resampling_rule():
    """Eq 19: flat likelihood -> N_eff = N and no resampling; otherwise resampled == (N_eff < n_th N)."""
    sysm = scalar_system(R=1e12)
    sim = sysm.simulate(5, 2, RunStreams.from_entropy(1, 2))
    res = IMMParticleFilter(sysm, 50, n_th=0.5).filter(sim.y, RunStreams.from_entropy(2, 2))
    assert np.allclose(res.diagnostics["ess"], 50.0) and not res.diagnostics["resampled"].any()
    sysm = scalar_system(R=0.01)
    sim = sysm.simulate(8, 3, RunStreams.from_entropy(1, 3))
    res = IMMParticleFilter(sysm, 50, n_th=0.5).filter(sim.y, RunStreams.from_entropy(2, 3))
    e = res.diagnostics["ess"]
    assert np.all((e >= 1 - 1e-9) & (e <= 50 + 1e-9)) and e.min() < 25
    assert np.array_equal(res.diagnostics["resampled"], e < 25)


# -- the readings of IMMPFOR (book/60_immpf.md, free choices "replace", "density") and the ablation --------
def _one_mode_case():
    """One scalar mode (r = 1), N = 4: x = 0, 1, 2, 3 with weights 0.7, 0.1, 0.1, 0.1; counts 2, 1, 1, 0
    (particle 3 is discarded, the extra copy of particle 0 sits in slot 1)."""
    m = LinearGaussianModel([[1.0]], [[1.0]], [[1.0]], [[1.0]], x0=[0.0], m0=[0.0], P0=[[1.0]])
    sysm = JumpMarkovSystem([m], [[1.0]])
    x = np.array([0.0, 1.0, 2.0, 3.0]).reshape(1, 1, 4, 1)
    w = np.array([0.7, 0.1, 0.1, 0.1]).reshape(1, 1, 4)
    counts = np.array([2, 1, 1, 0]).reshape(1, 1, 4)
    return sysm, x, w, counts


@pytest.mark.parametrize("density", ["gaussian", "weights"])
def test_replacement_step_by_hand(density):
    sysm, x, w, counts = _one_mode_case()
    f = IMMPFOR(sysm, 4, d=1.0, density=density)
    u, M = np.array([[1.0]]), np.ones((1, 1, 1))
    new, nd = f.replacement(x, w, u, M, counts, np.zeros((1, 1, 4), dtype=np.intp))
    m, L, z = IMMPFOR.joint_whitening(x, w, u)
    z0, z3 = z[0, 0, 0, 0], z[0, 0, 3, 0]
    if density == "weights":   # p = w' = 0.7 (eq 24 with r = 1): L = Gamma(2) / (1 * 4 * 0.7 * V_1), V_1 = 2
        step = 1.0 / (4 * 0.7 * 2.0)
    else:                      # p = N(z0; 0, 1)
        step = 1.0 / (4 * norm.pdf(z0) * 2.0)
    frac = min(1.0, step / abs(z3 - z0))
    expected = m[0, 0] + L[0, 0, 0] * (z0 + frac * (z3 - z0))
    assert nd[0, 0] == 1
    assert np.isclose(new[0, 0, 1, 0], expected, rtol=1e-12)
    np.testing.assert_array_equal(new[0, 0, [0, 2, 3], 0], [0.0, 1.0, 2.0])   # the copies themselves


def test_own_parent_ablation_and_vanishing_step_give_the_resampled_set():
    """mix_modes=False moves only the slot's own parent; with d -> 0 the new particle is that parent,
    so the replaced set is the standard resampled set; with mixing it is a mixture of parents."""
    rng = np.random.default_rng(7)
    x = rng.normal(size=(2, 3, 30, 6))
    w = rng.random((2, 3, 30)); w /= w.sum(-1, keepdims=True)
    u = np.array([[0.5, 0.3, 0.2], [0.1, 0.1, 0.8]])
    M = np.full((2, 3, 3), 1 / 3)
    # systematic counts with offset 1/2 (every mode has extra copies and discarded particles)
    counts = np.stack([[np.bincount(np.minimum(np.searchsorted(np.cumsum(w[a, j]), (np.arange(30) + 0.5) / 30), 29),
                                    minlength=30) for j in range(3)] for a in range(2)])
    other = rng.integers(0, 30, size=(2, 3, 30))
    idx = _indices_from_counts(counts)
    own = IMMPFOR(tracking_system(), 30, d=1e-9, mix_modes=False).replacement(x, w, u, M, counts, other)[0]
    std = np.take_along_axis(x, idx[..., None], axis=2)
    assert np.allclose(own, std, atol=1e-6)
    mixed = IMMPFOR(tracking_system(), 30, d=1e-9).replacement(x, w, u, M, counts, other)[0]
    assert not np.allclose(mixed, std, atol=1e-3)


def test_replace_always_resamples_every_mode_every_step():
    sysm = tracking_system()
    sim = sysm.simulate(6, 2, RunStreams.from_entropy(4, 2))
    res = IMMPFOR(sysm, 40, replace="always").filter(sim.y, RunStreams.from_entropy(5, 2))
    assert res.diagnostics["resampled"].all()
    assert np.all(res.diagnostics["density_evals"] == 6 * 3 * 40)
    thr = IMMPFOR(sysm, 40, n_th=0.0).filter(sim.y, RunStreams.from_entropy(5, 2))
    assert not thr.diagnostics["resampled"].any()
    with pytest.raises(ValueError):
        IMMPFOR(sysm, 40, replace="sometimes")
    with pytest.raises(ValueError):
        IMMPFOR(sysm, 40, density="kde")


def test_imm_evaluations_and_equal_compute_count_transitions():
    """Hand count: T = 10, r = 3, N = 100: transitions 3000, likelihoods 3000, densities 600 ->
    6600 per run; an IMMPF with N' costs 2 r N' T = 60 N', so N' = 110 (not 120 without transitions)."""
    from pfrepro.cost import imm_evaluations
    from pfrepro.experiments.immpfor_zhou2017 import equal_compute_N
    from pfrepro.filters.base import FilterResult

    res = FilterResult(np.zeros((2, 10, 6)), None, {"likelihood_evals": np.array([3000, 3000]),
                                                    "density_evals": np.array([600, 600])})
    np.testing.assert_array_equal(imm_evaluations(res, 100, 3), [6600.0, 6600.0])
    assert equal_compute_N(res, 100, 3) == 110
    pf = FilterResult(np.zeros((1, 10, 6)), None, {"likelihood_evals": np.array([3000])})
    assert imm_evaluations(pf, 100, 3)[0] == 6000


def test_robustness_rule_median_and_lost_tracks():
    from pfrepro.experiments import immpfor_zhou2017 as E
    from pfrepro.filters.base import FilterResult
    from pfrepro.models.base import Simulation

    runs, T = 40, 5
    xt = np.zeros((runs, T + 1, 6))
    err_a = np.full((runs, T), 100.0)
    def res(err):
        x = np.zeros((runs, T, 6)); x[..., 0] = err
        return FilterResult(x, None, {})
    run_ = lambda eb: E.Run(Simulation(xt, np.zeros((runs, T, 3))), {"A": res(err_a), "B": res(eb)}, 0)
    better = E.robustness(run_(np.full((runs, T), 90.0)), "A", "B")
    assert better["holds"] is True and better["b_better"] == runs and better["lost_b"] == 0
    eb = np.full((runs, T), 90.0); eb[:3, -1] = 1e4           # better in most runs but loses 3 tracks
    assert E.robustness(run_(eb), "A", "B")["holds"] is False
    assert E.robustness(run_(np.full((runs, T), 100.0)), "A", "B")["holds"] is None


def test_generated_prose_sign_and_plural():
    from pfrepro.experiments.immpfor_zhou2017 import compare_sentence, plural

    assert plural(1, "scenario") == "1 scenario" and plural(3, "scenario") == "3 scenarios"
    assert "exceeds" in compare_sentence(10.0, 2.0, "A", "B") and "+10.0" in compare_sentence(10.0, 2.0, "A", "B")
    assert "is below" in compare_sentence(-10.0, 2.0, "A", "B")
    assert "within two standard errors" in compare_sentence(1.0, 2.0, "A", "B")


def test_put_rows_converts_values_to_the_arrays_dtype():
    from pfrepro.filters.imm import _put_rows

    a = np.zeros((4, 3))
    _put_rows(a, np.array([2, 0]), np.array([[1, 2, 3], [4, 5, 6]], dtype=np.int64))
    np.testing.assert_array_equal(a, [[4, 5, 6], [0, 0, 0], [1, 2, 3], [0, 0, 0]])


# -- mutation-testing survivors (issue 21) ------------------------------------------------------
def test_model_likelihood_weights_are_normalised_per_run_and_mode():
    """Previous log-weights on very different scales in two runs (1e4 apart): each (run, mode)
    row is normalised on its own, so the batch equals the rows alone (a max over the whole
    batch would underflow the second run's weights to 0)."""
    sysm = scalar_system(R=1.0)
    f = IMMParticleFilter(sysm, 3)
    eps = np.array([1.0, 2.0, 4.0, 0.5, -1.0, 3.0]).reshape(2, 1, 3, 1)
    logw = np.log(np.array([[0.5, 0.3, 0.2], [0.2, 0.2, 0.6]]))[:, None, :]
    logw[1] -= 1e4
    ll = norm.logpdf(eps[..., 0])
    both = f.model_log_likelihood(eps, logw, ll)
    for r in range(2):
        np.testing.assert_allclose(both[r], f.model_log_likelihood(eps[r:r + 1], logw[r:r + 1], ll[r:r + 1])[0],
                                   rtol=1e-14)
    assert np.all(np.isfinite(both))


def test_m0_P0_overrides_and_diagnostic_dtypes():
    sysm = scalar_system()
    f = IMMParticleFilter(sysm, 20, m0=[2.0], P0=[[0.5]])
    np.testing.assert_array_equal(f.m0, [2.0])
    np.testing.assert_array_equal(f.P0, [[0.5]])
    y = sysm.simulate(3, 2, RunStreams.from_entropy(0, 2)).y
    a = f.filter(y, RunStreams.from_entropy(1, 2))
    b = IMMParticleFilter(sysm, 20).filter(y, RunStreams.from_entropy(1, 2))
    assert not np.array_equal(a.x, b.x)                  # the override is used
    d = a.diagnostics
    assert d["collapsed"].dtype == bool
    assert d["likelihood_evals"].dtype == d["density_evals"].dtype == np.int64


def test_diagonal_metric_equals_whitened_in_one_dimension():
    """In 1-D the standard deviation is the Cholesky factor: both metrics give the same particles."""
    sysm, x, w, counts = _one_mode_case()
    u, M, other = np.array([[1.0]]), np.ones((1, 1, 1)), np.zeros((1, 1, 4), dtype=np.intp)
    for density in ("gaussian", "weights"):
        a = IMMPFOR(sysm, 4, density=density).replacement(x, w, u, M, counts, other)[0]
        b = IMMPFOR(sysm, 4, density=density, metric="diagonal").replacement(x, w, u, M, counts, other)[0]
        np.testing.assert_allclose(a, b, rtol=1e-12)
    with pytest.raises(ValueError, match="metric"):
        IMMPFOR(sysm, 4, metric="euclidean")


def test_diagonal_metric_step_by_hand():
    """2-D, one mode, correlated cloud: the new particle is x_a + frac (x_s - x_a) with
    frac = d Gamma(3/2) / (N p(z_a) V_2)^(1/2) / ||D^-1 (x_s - x_a)||, p = N(z; 0, D^-1 C D^-1)."""
    from math import gamma, pi
    m1 = LinearGaussianModel(np.eye(2), np.eye(2), np.eye(2), np.eye(2), x0=[0, 0], m0=[0, 0], P0=np.eye(2))
    sysm = JumpMarkovSystem([m1], [[1.0]])
    x = np.array([[0.0, 0.0], [1.0, 3.0], [2.0, 5.0], [3.0, 6.5]]).reshape(1, 1, 4, 2)
    w = np.array([0.7, 0.1, 0.1, 0.1]).reshape(1, 1, 4)
    counts = np.array([2, 1, 1, 0]).reshape(1, 1, 4)
    u, M = np.array([[1.0]]), np.ones((1, 1, 1))
    new = IMMPFOR(sysm, 4, metric="diagonal").replacement(x, w, u, M, counts, np.zeros((1, 1, 4), dtype=np.intp))[0]
    m, L, _ = IMMPFOR.joint_whitening(x, w, u)
    C = L[0] @ L[0].T
    sd = np.sqrt(np.diag(C))
    Rc = C / np.outer(sd, sd)
    xa, xs = x[0, 0, 0], x[0, 0, 3]
    za, zs = (xa - m[0]) / sd, (xs - m[0]) / sd
    p = np.exp(-0.5 * za @ np.linalg.solve(Rc, za)) / (2 * pi * np.sqrt(np.linalg.det(Rc)))
    step = gamma(1.5) / np.sqrt(4 * p * pi)
    frac = min(1.0, step / np.linalg.norm(zs - za))
    np.testing.assert_allclose(new[0, 0, 1], xa + frac * (xs - xa), rtol=1e-10)
    whit = IMMPFOR(sysm, 4).replacement(x, w, u, M, counts, np.zeros((1, 1, 4), dtype=np.intp))[0]
    assert not np.allclose(whit[0, 0, 1], new[0, 0, 1])


# -- kept particle sets (the distance to the posterior, book/60_immpf.md) ---------------------------
@pytest.mark.parametrize("cls", [IMMParticleFilter, IMMPFOR])
def test_kept_particle_sets_are_the_estimates_sets(cls):
    """The kept particles and weights are the ones eqs 20-21 average: their mode-weighted mean is the
    estimate at that step; keeping them changes no number."""
    sysm = tracking_system()
    sim = sysm.simulate(12, 3, RunStreams.from_entropy(4, 3))
    plain = cls(sysm, 40, n_th=0.9).filter(sim.y, RunStreams.from_entropy(5, 3))
    kept = cls(sysm, 40, n_th=0.9, keep_steps=(2, 7, 12)).filter(sim.y, RunStreams.from_entropy(5, 3))
    np.testing.assert_array_equal(plain.x, kept.x)
    x, w = kept.diagnostics["particles"], kept.diagnostics["particle_weights"]
    assert x.shape == (3, 3, 3, 40, 6) and w.shape == (3, 3, 3, 40)
    np.testing.assert_allclose(w.sum(-1), 1.0, rtol=1e-12)
    for i, k in enumerate((2, 7, 12)):
        u = kept.diagnostics["mode_probs"][:, k - 1]
        est = np.einsum("ar,ari->ai", u, np.einsum("arn,arni->ari", w[:, i], x[:, i]))
        np.testing.assert_allclose(est, kept.x[:, k - 1], rtol=1e-12, atol=1e-9)
    assert "particles" not in plain.diagnostics


@pytest.mark.parametrize("bad, err", [((0, 3), ValueError), ((3, 3), ValueError), ((5, 2), ValueError),
                                      ((13,), ValueError), ("12", TypeError), (2.5, TypeError)])
def test_keep_steps_checked(bad, err):
    sysm = tracking_system()
    sim = sysm.simulate(12, 1, RunStreams.from_entropy(4, 1))
    with pytest.raises(err, match="keep_steps"):
        IMMParticleFilter(sysm, 10, keep_steps=bad).filter(sim.y, RunStreams.from_entropy(5, 1))


def test_weighted_w1_against_scipy_and_closed_forms():
    from scipy.stats import wasserstein_distance

    from pfrepro.experiments.immpfor_zhou2017 import weighted_w1

    rng = np.random.default_rng(3)
    a, b = rng.normal(size=(4, 30)), rng.standard_t(3, size=(4, 70))
    wa, wb = rng.random((4, 30)), rng.random((4, 70))
    wa, wb = wa / wa.sum(-1, keepdims=True), wb / wb.sum(-1, keepdims=True)
    ours = weighted_w1(a, wa, b, wb)
    ref = [wasserstein_distance(a[i], b[i], wa[i], wb[i]) for i in range(4)]
    np.testing.assert_allclose(ours, ref, rtol=1e-12)
    assert weighted_w1(a, wa, a, wa) == pytest.approx(0.0, abs=1e-15)        # a set against itself
    np.testing.assert_allclose(weighted_w1(a, wa, a + 2.5, wa), 2.5, rtol=1e-12)   # a shift moves it by the shift


def test_posterior_w1_zero_against_itself_and_needs_kept_sets():
    """A filter's set against itself is at distance 0; against another filter's set it is positive; a
    filter built without kept sets is refused with the builder to use."""
    from pfrepro.experiments import immpfor_zhou2017 as E

    steps = (3, 6)
    r_ = E.run(E.posterior_builders(E.PF_BUILDERS, steps=steps), runs=2)
    np.testing.assert_allclose(E.posterior_w1(r_, "IMMPF", "IMMPF", steps=steps), 0.0, atol=1e-9)   # rounding only
    assert np.all(E.posterior_w1(r_, "IMMPF", "IMMPFOR", steps=steps) > 0)
    plain = E.run({"IMMPF": ("immpf", {})}, runs=1)
    with pytest.raises(ValueError, match="posterior_builders"):
        E.posterior_w1(plain, "IMMPF", "IMMPF", steps=steps)
