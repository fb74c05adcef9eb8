"""pfrepro.filters.smc_steps, the resampling and reporting steps the 'today's methods' particle
filters share, by hand-computed cases (issue 21, mutation testing)."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from pfrepro.filters.particle import WeightCollapseWarning
from pfrepro.filters.smc_steps import particle_result, repeat_rows, resample_runs
from pfrepro.rng import RunStreams


def test_repeat_rows_by_hand():
    """Run 0 keeps rows (0, 0, 2), run 1 (1, 2, 2); every array (any trailing shape) alike."""
    counts = np.array([[2, 0, 1], [0, 1, 2]])
    x = np.arange(6.0).reshape(2, 3)                      # (runs, N)
    v = np.arange(12).reshape(2, 3, 2)                    # (runs, N, 2)
    rx, rv = repeat_rows(counts, x, v)
    np.testing.assert_array_equal(rx, [[0.0, 0.0, 2.0], [4.0, 5.0, 5.0]])
    np.testing.assert_array_equal(rv, [[[0, 1], [0, 1], [4, 5]], [[8, 9], [10, 11], [10, 11]]])
    assert rx.shape == x.shape and rv.shape == v.shape
    assert repeat_rows(counts) == []


def test_resample_runs_only_where_asked_and_from_the_runs_own_streams():
    """do = (True, False, True): runs 0 and 2 take their offspring counts from counts_of
    (given the weights of those runs and the streams of those runs only), their log-weights
    become -log N; run 1 is left as it was. Every run resampling passes the whole rng."""
    N = 4
    w = np.array([[0.7, 0.1, 0.1, 0.1], [0.25] * 4, [0.1, 0.1, 0.1, 0.7]])
    logw = np.log(w)
    x = np.tile(np.arange(4.0), (3, 1))
    v = np.tile(np.arange(4.0)[:, None] * 10, (3, 1, 2))
    rs = RunStreams.from_entropy(1, 3)
    seen = {}

    def counts_of(ws, rng):
        seen["w"], seen["rng"] = ws.copy(), rng
        c = np.zeros(ws.shape, dtype=np.intp)
        c[np.arange(len(ws)), ws.argmax(axis=1)] = N      # all offspring to the heaviest particle
        return c

    sel = resample_runs(np.array([True, False, True]), w, logw, rs, counts_of, x, v)
    assert sel.tolist() == [0, 2]
    np.testing.assert_array_equal(seen["w"], w[[0, 2]])
    assert list(seen["rng"]) == [rs[0], rs[2]]
    np.testing.assert_array_equal(x, [[0.0] * 4, [0.0, 1.0, 2.0, 3.0], [3.0] * 4])
    np.testing.assert_array_equal(v[:, :, 0], [[0.0] * 4, [0.0, 10.0, 20.0, 30.0], [30.0] * 4])
    np.testing.assert_array_equal(logw[[0, 2]], np.full((2, N), -np.log(N)))
    np.testing.assert_array_equal(logw[1], np.log(w[1]))
    resample_runs(np.ones(3, bool), w, logw, rs, counts_of, x)
    assert seen["rng"] is rs
    g = np.random.default_rng(0)
    resample_runs(np.array([False, True, False]), w, logw, g, counts_of, x)
    assert seen["rng"] is g
    seen.clear()
    assert resample_runs(np.zeros(3, bool), w, logw, rs, counts_of, x).tolist() == [] and not seen


def test_particle_result_sums_the_evidence_and_warns_once_on_collapse():
    xs = np.zeros((2, 3, 1))
    log_inc = np.array([[-1.0, -2.0, -0.5], [0.0, -1.0, -1.0]])
    collapsed = np.array([[False, True, False], [False, False, False]])
    with pytest.warns(WeightCollapseWarning, match=r"^APF: weight collapse in 1 of 6 run-steps"):
        r = particle_result("APF", xs, log_inc, collapsed, ess=np.ones((2, 3)))
    assert r.x is xs and r.P is None
    np.testing.assert_array_equal(r.diagnostics["log_evidence"], [-3.5, -2.0])
    assert r.diagnostics["n_collapsed"] == 1 and type(r.diagnostics["n_collapsed"]) is int
    assert r.diagnostics["collapsed"] is collapsed and r.diagnostics["ess"].shape == (2, 3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ok = particle_result("APF", xs, log_inc, np.zeros((2, 3), bool))
    assert ok.diagnostics["n_collapsed"] == 0
