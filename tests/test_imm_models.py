"""Jump-Markov systems and the manoeuvring-target models (Zhou et al. 2017, sec 1 and 3)."""
import math

import numpy as np
import pytest

from pfrepro.models.jump_markov import (JumpMarkovSystem, schedule_from_segments, simulate_modes,
                                        stationary_distribution, validate_transition_matrix)
from pfrepro.models.tracking import (ca_axis, coupled_ct_matrix, ct_axis, ct_model, cv_axis, cv_model,
                                     block_diag_axes, process_noise_Q, radar_h, radar_jacobian)
from pfrepro.rng import RunStreams

X0 = np.array([60000.0, -172.0, 0.0, 40000.0, 200.0, 0.0])
MEAS = (100.0, 5.0, 0.01)
PI3 = np.array([[0.8, 0.15, 0.05], [0.2, 0.7, 0.1], [0.1, 0.3, 0.6]])


# -- transition matrix ----------------------------------------------------------------------------
@pytest.mark.parametrize("bad, msg", [
    ([[0.9, 0.2], [0.5, 0.5]], "sum to 1"),
    ([[1.1, -0.1], [0.5, 0.5]], r"\[0, 1\]"),
    ([[0.5, 0.5, 0.0], [0.5, 0.5, 0.0]], "square"),
    ([[np.nan, 1.0], [0.5, 0.5]], "NaN"),
    ([0.5, 0.5], "square"),
])
def test_transition_matrix_refused(bad, msg):
    with pytest.raises(ValueError, match=msg):
        validate_transition_matrix(bad)


def test_transition_matrix_wrong_size_for_modes():
    with pytest.raises(ValueError, match="3x3"):
        validate_transition_matrix(np.eye(2), r=3)
    m = cv_model(1.0, 1.0, MEAS, X0)
    with pytest.raises(ValueError, match="2x2"):
        JumpMarkovSystem([m, m], np.eye(3))
    with pytest.raises(ValueError, match="initial_probs"):
        JumpMarkovSystem([m, m], np.eye(2), initial_probs=[0.7, 0.7])


def test_stationary_distribution_hand():
    # two-state chain: pi_0 = b / (a + b) with a = P(0->1), b = P(1->0)
    P = np.array([[0.9, 0.1], [0.3, 0.7]])
    assert np.allclose(stationary_distribution(P), [0.75, 0.25])


def test_mode_frequencies_match_matrix_and_stationary():
    runs, T = 200, 500
    modes = simulate_modes(PI3, [1.0, 0.0, 0.0], T, runs, RunStreams.from_entropy(7, runs))
    a, b = modes[:, :-1].ravel(), modes[:, 1:].ravel()
    for i in range(3):
        sel = a == i
        n = sel.sum()
        freq = np.bincount(b[sel], minlength=3) / n
        se = np.sqrt(PI3[i] * (1 - PI3[i]) / n)
        assert np.all(np.abs(freq - PI3[i]) < 4 * se + 1e-12), (i, freq, PI3[i])
    # after burn-in the marginal is the stationary distribution (row convention: pi = pi @ P)
    pi = stationary_distribution(PI3)
    marg = np.bincount(modes[:, 100:].ravel(), minlength=3) / modes[:, 100:].size
    assert np.allclose(marg, pi, atol=0.02)
    # the transposed reading (column = from) would give a different stationary law here
    assert not np.allclose(stationary_distribution(PI3.T / PI3.T.sum(1, keepdims=True)), pi, atol=0.02)


def test_modes_batch_invariant():
    full = simulate_modes(PI3, [1 / 3] * 3, 50, 8, RunStreams.from_entropy(3, 8))
    one = simulate_modes(PI3, [1 / 3] * 3, 50, 1, RunStreams.from_entropy(3, 1, start=5))
    assert np.array_equal(full[5], one[0])


def test_schedule_and_deterministic_truth():
    T = 30
    sched = schedule_from_segments(T, [(5, 9, 1), (20, 24, 2)])
    assert sched[4] == 0 and sched[5] == 1 and sched[9] == 1 and sched[10] == 0 and sched[20] == 2
    with pytest.raises(ValueError):
        schedule_from_segments(T, [(5, 40, 1)])
    w = math.radians(3)
    from pfrepro.models.tracking import coupled_ct_model
    sysm = JumpMarkovSystem([cv_model(1.0, 0.0, MEAS, X0), coupled_ct_model(1.0, w, 0.0, MEAS, X0),
                             coupled_ct_model(1.0, -w, 0.0, MEAS, X0)], np.eye(3))
    sim = sysm.simulate(T, 2, RunStreams.from_entropy(1, 2), schedule=sched)
    assert np.array_equal(sim.modes[0], sched)
    # q = 0: the states follow the active mode's matrix exactly
    for k in range(1, T + 1):
        assert np.allclose(sim.x[:, k], sim.x[:, k - 1] @ sysm.models[sched[k]].F.T)
    speed = np.hypot(sim.x[0, :, 1], sim.x[0, :, 4])
    assert np.allclose(speed, speed[0])                       # turns keep the speed
    heading = np.unwrap(np.arctan2(sim.x[0, :, 4], sim.x[0, :, 1]))
    assert np.isclose(heading[9] - heading[4], 5 * w) and np.isclose(heading[24] - heading[19], -5 * w)


# -- motion models ---------------------------------------------------------------------------------
@pytest.mark.parametrize("w", [math.radians(3), -math.radians(3), math.radians(10)])
def test_per_axis_ct_follows_coupled_turn_in_both_directions(w):
    """The per-axis CT block equals the exact coordinated turn once a is centripetal (either sign of w)."""
    F_axis = block_diag_axes(ct_axis(1.0, abs(w))[0])
    Fc = coupled_ct_matrix(1.0, w)
    x = np.array([1000.0, -172.0, 0.0, 500.0, 200.0, 0.0])
    x[2], x[5] = -w * x[4], w * x[1]                           # centripetal acceleration a = w J v
    for _ in range(20):
        assert np.allclose(x @ F_axis.T, x @ Fc.T, rtol=1e-10, atol=1e-8)
        x = x @ Fc.T


def test_cv_ca_blocks_hand():
    F, G = cv_axis(2.0)
    assert np.allclose(F, [[1, 2, 0], [0, 1, 0], [0, 0, 0]]) and np.allclose(G, [2, 2, 0])
    F, G = ca_axis(2.0)
    assert np.allclose(F, [[1, 2, 2], [0, 1, 2], [0, 0, 1]]) and np.allclose(G, [2, 2, 1])
    # CT -> CA as w -> 0
    assert np.allclose(ct_axis(1.0, 1e-3)[0], ca_axis(1.0)[0], atol=1e-3)
    Q = process_noise_Q(G, 4.0)
    assert np.linalg.matrix_rank(Q) == 2 and np.allclose(Q[:3, :3], 4 * np.outer(G, G))


def test_low_rank_noise_has_covariance_Q():
    m = ct_model(1.0, 0.05, 4.0, MEAS, X0)
    assert np.allclose(m.noise_factor @ m.noise_factor.T, m.Q)
    x = np.zeros((4, 20000, 6))
    s = m.sample_transition(x, 1, RunStreams.from_entropy(2, 4)).reshape(-1, 6)
    C = np.cov(s.T)
    assert np.allclose(C, m.Q, atol=0.05 * np.abs(m.Q).max())


def test_radar_h_jacobian_and_wrapping():
    rng = np.random.default_rng(0)
    x = X0 + rng.normal(scale=[1000, 50, 1, 1000, 50, 1], size=(5, 6))
    H = radar_jacobian(x)
    eps = 1e-4 * np.maximum(np.abs(x), 1.0)
    for i in range(6):
        dx = np.zeros(6); dx[i] = eps[0, i]
        fd = (radar_h(x + dx) - radar_h(x - dx)) / (2 * dx[i])
        assert np.allclose(H[..., i], fd, rtol=1e-5, atol=1e-9)
    m = cv_model(1.0, 1.0, MEAS, X0)
    d = m.residual_y(np.array([1.0, 0.0, np.pi - 0.01]), np.array([0.0, 0.0, -np.pi + 0.01]))
    assert np.allclose(d, [1.0, 0.0, -0.02])
    assert np.allclose(radar_h(X0), [np.hypot(60000, 40000), (60000 * -172 + 40000 * 200) / np.hypot(60000, 40000),
                                     np.arctan2(40000, 60000)])


def test_tracking_model_refuses_bad_input():
    with pytest.raises(ValueError, match="sigma_r"):
        cv_model(1.0, 1.0, (0.0, 5.0, 0.01), X0)
    with pytest.raises(ValueError, match="q"):
        process_noise_Q([1, 1, 0], -1.0)
    with pytest.raises(ValueError, match="turn rate"):
        ct_axis(1.0, 0.0)
