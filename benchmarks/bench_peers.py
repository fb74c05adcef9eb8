"""Our filters against the peers a reader would otherwise use, interleaved in one run.

* Bootstrap PF on UNGM (``UNGM.zhang2016()``, T = 500): ours on one run against N. Chopin's
  ``particles`` (``SMC(fk=Bootstrap(ssm=...))``, systematic resampling every step), for
  N = 10², 10³, 10⁴, 10⁵. ``particles`` 0.4 (the newest release) requires numpy < 2 and this
  project pins numpy 2.4.6, so it cannot live in this environment; the script times
  ``particles`` when it imports (e.g. in a separate environment where both are installed
  with ``pip install --no-deps particles``), and otherwise says so and skips that column.
* IMM with Kalman mode filters on a 3-mode linear manoeuvring model (CV, CT, CA; position
  measurements; T = 300): filterpy's ``IMMEstimator`` (a Python loop, one run at a time) against
  our ``IMMKalman`` on one run and on 100 runs batched (time per run).

Each entry is the median of ``--repeats`` calls whose order is interleaved (A, B, A, B, ...),
so a drift of the machine's load hits both sides alike; only the ratios mean anything.
Not part of the tests or the book build. Run from the repository root::

    python benchmarks/bench_peers.py [--quick] [--csv benchmarks/results/bench_peers.csv]
"""
from __future__ import annotations

import argparse
import gc
import math
import time

import numpy as np
import pandas as pd

from pfrepro.filters import BootstrapParticleFilter, KalmanFilter
from pfrepro.filters.imm import IMMKalman
from pfrepro.models import UNGM
from pfrepro.models.jump_markov import JumpMarkovSystem
from pfrepro.models import LinearGaussianModel
from pfrepro.models.tracking import block_diag_axes, ca_axis, ct_axis, cv_axis, process_noise_Q
from pfrepro.montecarlo import filter_streams, truth_streams

try:  # optional peer (needs numpy < 2, see the module docstring)
    import particles
    from particles import state_space_models as ssms
except Exception as exc:  # noqa: BLE001 (report why, whatever it was)
    particles, _PARTICLES_ERROR = None, f"{type(exc).__name__}: {exc}"


def _median_time(fn, repeats):
    ts = []
    for _ in range(repeats):
        gc.collect()
        gc.disable()
        try:
            t0 = time.perf_counter()
            fn()
            ts.append(time.perf_counter() - t0)
        finally:
            gc.enable()
    return float(np.median(ts))


def _interleaved(fns: dict, repeats: int) -> dict:
    """Median seconds of each callable, the calls interleaved round by round."""
    times = {k: [] for k in fns}
    for _ in range(repeats):
        for k, fn in fns.items():
            times[k].append(_median_time(fn, 1))
    return {k: float(np.median(v)) for k, v in times.items()}


def pf_rows(Ns, T, repeats):
    model = UNGM.zhang2016()
    sim = model.simulate(T, 1, truth_streams(2016, 1))
    rows = []
    if particles is not None:
        class UNGMp(ssms.StateSpaceModel):  # the same model, in particles' terms
            def PX0(self):
                return particles.distributions.Normal(loc=float(model.m0[0]), scale=math.sqrt(model.P0[0, 0]))

            def PX(self, t, xp):
                return particles.distributions.Normal(loc=model.f(xp[:, None], t + 1)[:, 0], scale=1.0)

            def PY(self, t, xp, x):
                return particles.distributions.Normal(loc=model.h(x[:, None])[:, 0], scale=1.0)
    for N in Ns:
        ours = BootstrapParticleFilter(model, N)
        fns = {"ours single": lambda: ours.filter(sim.y, filter_streams(1, "PF", 1))}
        if particles is not None:
            fk = ssms.Bootstrap(ssm=UNGMp(), data=list(sim.y[0, :, 0]))
            fns["particles"] = lambda: particles.SMC(fk=fk, N=N, resampling="systematic", ESSrmin=1.0).run()
        t = _interleaved(fns, repeats)
        row = {"N": N, **{f"{k} ns/particle-step": 1e9 * v / (N * T) for k, v in t.items()}}
        if "particles" in t:
            row["particles / ours"] = t["particles"] / t["ours single"]
        rows.append(row)
    return pd.DataFrame(rows).set_index("N")


def imm_system():
    """CV, CT (3 deg/s) and CA modes of the IMM chapter's state (x, vx, ax, y, vy, ay), with
    linear position measurements (filterpy's IMMEstimator needs linear Kalman mode filters)."""
    H = np.zeros((2, 6))
    H[0, 0] = H[1, 3] = 1.0
    R = np.eye(2) * 100.0
    x0 = np.array([0.0, 10.0, 0.0, 0.0, 5.0, 0.0])
    P0 = np.diag([100.0, 25.0, 1.0, 100.0, 25.0, 1.0])
    ms = []
    for (F, G), q in ((cv_axis(1.0), 1.0), (ct_axis(1.0, math.radians(3)), 1.0), (ca_axis(1.0), 9.0)):
        Q = process_noise_Q(G, q) + 1e-9 * np.eye(6)   # a KF needs no more than PSD; filterpy neither
        ms.append(LinearGaussianModel(block_diag_axes(F), H, Q, R, x0, P0=P0))
    return JumpMarkovSystem(ms, [[0.9, 0.05, 0.05], [0.05, 0.9, 0.05], [0.05, 0.05, 0.9]])


def imm_rows(T, runs, repeats):
    from filterpy.kalman import IMMEstimator, KalmanFilter as FKF

    sysm = imm_system()
    sim = sysm.simulate(T, runs, truth_streams(2017, runs))
    ours = IMMKalman(sysm, [KalmanFilter(m) for m in sysm.models])

    def filterpy_one_run():
        fs = []
        for m in sysm.models:
            f = FKF(dim_x=m.dim_x, dim_z=m.dim_y)
            f.F, f.H, f.Q, f.R, f.x, f.P = m.F, m.H, m.Q, m.R, m.m0.copy(), m.P0.copy()
            fs.append(f)
        imm = IMMEstimator(fs, sysm.initial_probs.copy(), sysm.Pi)
        for k in range(T):
            imm.predict()
            imm.update(sim.y[0, k])

    t = _interleaved({"filterpy IMMEstimator (1 run)": filterpy_one_run,
                      "ours IMMKalman (1 run)": lambda: ours.filter(sim.y[:1]),
                      f"ours IMMKalman ({runs} runs)": lambda: ours.filter(sim.y)}, repeats)
    t[f"ours IMMKalman ({runs} runs)"] /= runs
    df = pd.Series({k: 1e6 * v / T for k, v in t.items()}, name="µs per step (per run)").to_frame()
    df["filterpy / this"] = df.iloc[0, 0] / df.iloc[:, 0]
    return df


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="N = 1e2, 1e3 only; 3 repeats")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--csv", default="")
    a = ap.parse_args(argv)
    Ns = (100, 1000) if a.quick else (100, 1000, 10_000, 100_000)
    repeats = 3 if a.quick else a.repeats
    if particles is None:
        print(f"particles not importable here ({_PARTICLES_ERROR}); timing ours only")
    pf = pf_rows(Ns, 500, repeats)
    imm = imm_rows(300, 100, repeats)
    print(pf.round(2).to_string())
    print(imm.round(2).to_string())
    if a.csv:
        pd.concat({"pf": pf.reset_index(), "imm": imm.reset_index()}).to_csv(a.csv)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
