"""An independent check of our SMC² against N. Chopin's ``particles`` on the synthesis's unknown-θ benchmark.

The benchmark (``pfrepro.experiments.synthesis``, key ``theta_hou``): the growth model of Hou & Yin (2008,
sec 5.1, eqs 12-13) with θ unknown, θ ~ U(0, 1), T = 100, truths from the synthesis's seed. On its first
``--runs`` runs the script computes the posterior mean of θ after the last measurement three ways:

* exact: the θ-grid filter of the dual-PF chapter (``pfrepro.experiments.dpf_hou2008.grid_51``);
* ours: ``pfrepro.filters.SMC2`` with the synthesis's size (``SMC2_SIZE``: M θ-particles × N_x);
* ``particles``: ``particles.smc_samplers.SMC2`` (Chopin, Jacob & Papaspiliopoulos 2013) with the same
  M and N_x, its defaults otherwise (waste-free moves, N_x fixed).

and prints, per SMC², the mean over the runs of (estimate − exact) with its standard error, and the mean
squared distance to the exact posterior mean. Both SMC² are consistent as M and N_x grow, so both should sit
near the exact value, within their Monte Carlo spread at this size; the check is independent because
``particles`` shares no code with this package.

``particles`` is NOT a dependency of this project. Its release 0.4 declares ``numpy<2`` although its SMC²
runs on the numpy 2 this project pins; install it without its declared dependencies, plus the three it
imports (numba, llvmlite, joblib), into this environment or a scratch copy of it::

    pip install --no-deps particles==0.4 numba llvmlite joblib

(checked with numba 0.68.1, llvmlite 0.50.0 and numpy 2.4.6; ``particles`` 0.4 reports itself as
"0.3alpha"). One run of ``--runs 3`` (seed 1), as an example of the output: mean(estimate − exact)
−0.0005 ± 0.0040 for ours and +0.0002 ± 0.0050 for ``particles``; ``particles`` took 360 s for the
three runs on a loaded two-core machine.

The script says so and exits cleanly (status 0) when ``particles`` does not import. Not part of the tests or
the book build. Run from the repository root::

    python benchmarks/check_smc2_particles.py [--runs 5] [--seed 1]
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from importlib.metadata import version as _version

import numpy as np

from pfrepro.experiments import dpf_hou2008 as DPF
from pfrepro.experiments import synthesis as S
from pfrepro.filters import SMC2
from pfrepro.montecarlo import run_monte_carlo

try:  # optional peer: not in requirements.txt (see the module docstring)
    import particles
    from particles import distributions as dists
    from particles import smc_samplers as ssp
    from particles import state_space_models as ssm
except Exception as exc:  # noqa: BLE001 (report why, whatever it was)
    particles, _PARTICLES_ERROR = None, f"{type(exc).__name__}: {exc}"


def _particles_model(model):
    """The benchmark's model in ``particles``' terms. ``particles`` observes Y_0 at X_0; ours draws x_0 from
    the prior and observes y_1 at x_1 = f(x_0, 1) + w, so ``particles``' X_t is our x_{t+1}: its initial law is
    that of x_1 (drawn by simulation; a bootstrap filter only samples it) and its step t uses our k = t + 1."""
    sd0 = math.sqrt(float(model.P0[0, 0]))
    m0 = float(model.m0[0])
    q, r = math.sqrt(float(model.Q[0, 0])), math.sqrt(float(model.R[0, 0]))

    def f(x, k, theta):
        return theta * x + model.beta * x / (1.0 + x * x) + model.gamma * np.cos(model.omega * k)

    class FirstState(dists.ProbDist):
        def __init__(self, theta):
            self.theta = theta

        def rvs(self, size=None):
            x0 = m0 + sd0 * np.random.normal(size=size)
            return f(x0, 1, self.theta) + q * np.random.normal(size=size)

    class UNGMTheta(ssm.StateSpaceModel):
        default_params = {"theta": 0.5}

        def PX0(self):
            return FirstState(self.theta)

        def PX(self, t, xp):
            return dists.Normal(loc=f(xp, t + 1, self.theta), scale=q)

        def PY(self, t, xp, x):
            return dists.Normal(loc=x * x / 20.0, scale=r)

    return UNGMTheta


def particles_theta_mean(model, y, M: int, n_x: int, seed: int) -> float:
    """``particles``' SMC² posterior mean of θ after the last measurement of ``y`` (T,)."""
    np.random.seed(seed)   # particles draws from numpy's global generator
    lo, hi = model.bounds
    prior = dists.StructDist({"theta": dists.Uniform(a=float(lo), b=float(hi))})
    fk = ssp.SMC2(ssm_cls=_particles_model(model), prior=prior, data=list(np.asarray(y, float)), init_Nx=n_x)
    alg = particles.SMC(fk=fk, N=M, verbose=False)
    alg.run()
    return float(np.average(alg.X.theta["theta"], weights=alg.W))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=5, help="first runs of the benchmark's truths (default 5)")
    ap.add_argument("--seed", type=int, default=1, help="seed of particles' global generator (default 1)")
    args = ap.parse_args(argv)
    if particles is None:
        print(f"particles is not installed ({_PARTICLES_ERROR}); install it with "
              "'pip install --no-deps particles==0.4 numba llvmlite joblib' to run this check. Skipped.")
        return 0
    if args.runs < 2:
        raise SystemExit("--runs must be at least 2 (a standard error needs two runs)")
    model = DPF.model_51()
    M, n_x = S.SMC2_SIZE
    name = f"SMC²({M}×{n_x})"
    mc = run_monte_carlo(model, {"exact": DPF.grid_51(model), name: SMC2(model, M, n_x)}, DPF.S51["T"], args.runs,
                         S.SEEDS["theta_hou"], progress=False)
    exact = np.asarray(mc.results["exact"].diagnostics["theta"], float)[:, -1]
    ours = np.asarray(mc.results[name].diagnostics["theta"], float)[:, -1]
    t0 = time.perf_counter()
    theirs = np.array([particles_theta_mean(model, mc.sim.y[i, :, 0], M, n_x, args.seed + i)
                       for i in range(args.runs)])
    secs = time.perf_counter() - t0
    print(f"posterior mean of θ after T = {DPF.S51['T']} on the first {args.runs} runs of the synthesis's "
          f"unknown-θ truths (seed {S.SEEDS['theta_hou']}); particles {_version('particles')}, "
          f"numpy {np.__version__}")
    print(f"{'run':>4} {'exact (grid)':>13} {'ours':>9} {'particles':>10}")
    for i in range(args.runs):
        print(f"{i:>4} {exact[i]:>13.4f} {ours[i]:>9.4f} {theirs[i]:>10.4f}")
    for label, est in (("ours", ours), ("particles", theirs)):
        d = est - exact
        print(f"{label:>10}: mean(estimate − exact) {d.mean():+.4f} ± {d.std(ddof=1) / math.sqrt(d.size):.4f}, "
              f"mean squared distance {np.mean(d * d):.2e}")
    print(f"particles' SMC² took {secs:.1f} s for {args.runs} runs (one run at a time, not batched)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
