"""The shared resampling and reporting steps of today's particle filters (filters/smc_steps.py),
pinned with the real resampling schemes (issue 35; test_smc_steps.py pins them with a stub
counts function).

* the weights after resampling: -log N in the runs that resample, the old log-weights kept in
  the others, the normalised weights untouched;
* the particles after resampling: every array of a particle (state, mode, per-particle matrix)
  repeated by the SAME offspring counts, ancestors in order, by hand for systematic resampling
  with a known uniform;
* per-run streams: a run resampled in a batch gets what it gets alone;
* the result: evidence summed over time (not over runs), the filter's diagnostics passed on.

Each test was checked once against the wrong formula named in its docstring.
"""
from __future__ import annotations

import numpy as np
import pytest

from pfrepro.filters.particle import WeightCollapseWarning
from pfrepro.filters.resampling import resampling_counts_function
from pfrepro.filters.smc_steps import particle_result, repeat_rows, resample_runs
from pfrepro.rng import RunStreams


class FixedUniform(np.random.Generator):
    """A Generator whose ``random`` returns ``u`` everywhere: systematic resampling with U = u."""

    def __init__(self, u):
        super().__init__(np.random.PCG64(0))
        self.u = u

    def random(self, size=None, dtype=np.float64, out=None):
        return np.full(size, self.u)


# three runs, N = 4; systematic counts with U = 0.5: counts_i = ceil(4 C_i - 1/2) - ceil(4 C_{i-1} - 1/2)
#   run 0: w = (0.1, 0.6, 0.2, 0.1): 4 C = (0.4, 2.8, 3.6, 4) -> ceil(. - .5) = (0, 3, 4, 4) -> counts (0, 3, 1, 0)
#   run 1: w = (0.25, 0.25, 0.25, 0.25)                                   (not resampled)
#   run 2: w = (0.5, 0.0, 0.0, 0.5): 4 C = (2, 2, 2, 4) -> (2, 2, 2, 4) -> counts (2, 0, 0, 2)
W = np.array([[0.1, 0.6, 0.2, 0.1], [0.25] * 4, [0.5, 0.0, 0.0, 0.5]])
DO = np.array([True, False, True])


def _arrays():
    x = np.arange(24.0).reshape(3, 4, 2)                        # (runs, N, n)
    mode = np.array([[0, 1, 2, 3], [4, 5, 6, 7], [8, 9, 10, 11]])
    P = np.arange(3 * 4 * 4, dtype=float).reshape(3, 4, 2, 2)    # per-particle matrices
    return x, mode, P


def test_systematic_resampling_of_chosen_runs_by_hand():
    """Runs 0 and 2 resample with counts (0, 3, 1, 0) and (2, 0, 0, 2); every array of the particle
    follows the same ancestors; run 1 is left alone. Checked against the wrong formula once:
    resampling every run (run 1's rows and log-weights change)."""
    x, mode, P = _arrays()
    x0, P0 = x.copy(), P.copy()
    with np.errstate(divide="ignore"):
        logw = np.log(W)
    w_before, logw1 = W.copy(), logw[1].copy()
    sel = resample_runs(DO, W, logw, FixedUniform(0.5), resampling_counts_function("systematic"), x, mode, P)
    np.testing.assert_array_equal(sel, [0, 2])
    anc = {0: [1, 1, 1, 2], 1: [0, 1, 2, 3], 2: [0, 0, 3, 3]}
    for r, a in anc.items():
        np.testing.assert_array_equal(x[r], x0[r, a])
        np.testing.assert_array_equal(P[r], P0[r, a])
        np.testing.assert_array_equal(mode[r], 4 * r + np.array(a))
    # weights after resampling: 1/N where resampled, the old ones elsewhere; w itself untouched
    np.testing.assert_array_equal(logw[[0, 2]], np.full((2, 4), -np.log(4)))
    np.testing.assert_array_equal(logw[1], logw1)
    np.testing.assert_array_equal(W, w_before)
    assert mode.dtype.kind == "i"


def test_a_run_resampled_in_a_batch_gets_what_it_gets_alone():
    """RunStreams: run 2 resampled together with run 0 draws from stream 2, exactly as run 2
    resampled on its own (stratified: one uniform per particle, so a shared stream would shift
    them). Checked against the wrong formula once: take_runs(rng, arange(len(sel))) (runs 0 and 2
    take streams 0 and 1; the whole RunStreams for a subset is refused by its size check)."""
    counts_of = resampling_counts_function("stratified")
    w = np.array([[0.3, 0.3, 0.2, 0.2], [0.1, 0.2, 0.3, 0.4], [0.4, 0.1, 0.1, 0.4]])
    x = np.tile(np.arange(4.0), (3, 1))
    logw = np.log(w)
    resample_runs(DO, w, logw, RunStreams.from_entropy(9, 3), counts_of, x)
    alone = np.arange(4.0)[None].copy()
    resample_runs(np.array([True]), w[2:], np.log(w[2:]), RunStreams.from_entropy(9, 1, start=2), counts_of, alone)
    np.testing.assert_array_equal(x[2], alone[0])
    np.testing.assert_array_equal(x[1], np.arange(4.0))


def test_repeat_rows_keeps_ancestor_order_per_run():
    """counts (0, 3, 1, 0): rows (1, 1, 1, 2) -- not (2, 1, 1, 1) -- for a 4-D array; a count of N
    on one row fills the run with it. Checked against the wrong formula once: repeating the
    flattened (runs N, ...) array with the counts of run 0 for every run."""
    P = np.arange(2 * 4 * 2 * 2.0).reshape(2, 4, 2, 2)
    counts = np.array([[0, 3, 1, 0], [0, 0, 0, 4]])
    (out,) = repeat_rows(counts, P)
    np.testing.assert_array_equal(out[0], P[0, [1, 1, 1, 2]])
    np.testing.assert_array_equal(out[1], P[1, [3, 3, 3, 3]])
    assert out.shape == P.shape


def test_particle_result_sums_over_time_and_keeps_every_diagnostic():
    """Three runs, two steps: log_evidence = the sum over steps per run (axis 1), the filter's
    own diagnostics passed on unchanged; the collapse count over run-steps. Checked against the
    wrong formula once: log_inc.sum(axis=0) (a (T,) vector)."""
    xs = np.zeros((3, 2, 1))
    log_inc = np.array([[-1.0, -2.0], [0.5, -0.25], [-np.inf, -1.0]])
    collapsed = np.array([[False, False], [False, False], [True, True]])
    extra = np.arange(6.0).reshape(3, 2)
    with pytest.warns(WeightCollapseWarning, match=r"^JMPF: weight collapse in 2 of 6 run-steps"):
        r = particle_result("JMPF", xs, log_inc, collapsed, ess=extra, mode_probs=xs)
    np.testing.assert_array_equal(r.diagnostics["log_evidence"], [-3.0, 0.25, -np.inf])
    assert r.diagnostics["ess"] is extra and r.diagnostics["mode_probs"] is xs
    assert r.diagnostics["n_collapsed"] == 2
    assert set(r.diagnostics) == {"ess", "mode_probs", "log_evidence", "collapsed", "n_collapsed"}
