"""pfrepro: filters, models and experiment tools for the particle-filtering reproduction book.

Subpackages and modules
-----------------------
models       state-space models (UNGM family, CWPA, bearings-only tracking, stochastic volatility,
             models with a static parameter, re-entry, jump-Markov tracking) and the model contract
filters      Kalman family, particle filters and resampling, grid filters, the papers' filters
             (GPFF, CMS-PF, ESPF, dual PF, IMM-PF) and today's methods (APF, RPF, PFPF, SMC²...)
noise        Gaussian and Gaussian-mixture measurement noise
flow         particle-flow algebra of the GPFF
chaos        chaotic carrier sequences of the CMS-PF
bounds       posterior Cramér–Rao bounds
metrics      the papers' error measures with Monte Carlo standard errors
montecarlo   batched Monte Carlo runner with per-filter random streams and timings
results      what a filter returns (FilterResult), shared by the filters and the runner
rng          per-run random streams (RunStreams): run i independent of the batch
cost         deterministic cost counts and measured time for cost claims
published    the papers' published tables as data
claims       claims registry and the verdict rule behind the scorecard
stats        the claims' shared estimators: paired differences, ratios, bootstrap, equivalence, Holm
verdicts     one module per paper that decides its claims from its experiments' results
findings     what a chapter found, said first; the book's summary in the introduction
choices      free choices a paper leaves open, and the verdict under each reading
experiments  one module per paper: model, filters, settings, seeds, run_all
figures      the papers' figures and tables as functions
papers, cli  the paper registry and the ``pfrepro`` command line
export       tidy frames, CSV files and the book's download links
plotting     the book's figure style and palette
bookinfo     what a build of the book contains and what built it
prose        the chapters' glue helpers and generated sentences in number agreement
validation   input checks at the public API boundary
"""
from . import claims, filters, metrics, models, montecarlo, noise, published, rng

__version__ = "0.1.0"
__all__ = ["claims", "filters", "metrics", "models", "montecarlo", "noise", "published", "rng"]
