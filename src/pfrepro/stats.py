"""Statistics shared by the papers' claims: paired differences, ratios, bootstrap, equivalence, Holm.

Every ordering in the book is decided on per-run values of two methods over the *same* runs
(common random numbers). These are the estimators the chapters' claims use; they live here,
once, so that every paper judges a paired difference, a ratio of means or a median the same way.

* :func:`common_runs`, :func:`paired_difference` -- mean and SE of per-run differences;
* :func:`ratio_of_means` -- ``mean(a) / mean(b)`` with its delta-method SE;
* :func:`bootstrap_median` -- median of paired differences, bootstrap SE and 95 % interval;
* :func:`median_paired`, :func:`std_difference` -- median and spread orderings over finite pairs;
* :func:`equivalence` -- two one-sided tests at the 2-SE level against a margin;
* :func:`heavy_tailed` -- does one run carry more than a share of the total?
* :func:`p_two_sided`, :func:`holm` -- normal p-values and Holm's family-wise rule;
* :func:`plan_runs` -- the runs a paired comparison needs to show an effect of a given size.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

__all__ = ["CommonRunsError", "common_runs", "paired_difference", "ratio_of_means", "bootstrap_median",
           "median_paired", "std_difference", "equivalence", "heavy_tailed", "p_two_sided", "holm", "plan_runs", "Z_POWER"]


class CommonRunsError(ValueError):
    """A paired comparison over two different run sets."""


def common_runs(a, b):
    """Check that ``a`` and ``b`` are per-run values on the same run set; return them as float arrays.

    The book-wide rule "comparisons use common runs only": pandas objects carry their run
    labels (the index), which must be equal, in the same order; arrays must have the same
    shape (no broadcasting: one value against many runs, or 40 runs against 100, is refused).
    Select the common runs first (``a.loc[b.index]``, ``a[:n]``) when they differ. Raises
    :class:`CommonRunsError`.
    """
    ia = a.index if isinstance(a, (pd.Series, pd.DataFrame)) else None
    ib = b.index if isinstance(b, (pd.Series, pd.DataFrame)) else None
    if ia is not None and ib is not None and not ia.equals(ib):
        raise CommonRunsError(f"paired comparison over unequal run sets ({len(ia)} runs against {len(ib)}, "
                              "labels differ): compare on common runs only")
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape:
        raise CommonRunsError(f"paired comparison over unequal run sets (shapes {a.shape} and {b.shape}): "
                              "compare on common runs only")
    return a, b


def paired_difference(a, b):
    """Mean and standard error of the per-run differences ``a - b`` (common random numbers).

    ``a`` and ``b`` are per-run values of two methods on the *same* runs (same
    truths), checked by :func:`common_runs`. Returns ``(mean, se)`` with
    ``se = std(a - b, ddof=1) / sqrt(runs)``.
    """
    a, b = common_runs(a, b)
    d = a - b
    d = d.ravel()
    if d.size < 2 or not np.all(np.isfinite(d)):
        raise ValueError(f"paired_difference needs >= 2 finite paired values, got {d.size}")
    return float(d.mean()), float(d.std(ddof=1) / np.sqrt(d.size))


def ratio_of_means(a, b) -> tuple[float, float]:
    """mean(a) / mean(b) for paired per-run values, with its delta-method standard error."""
    a = np.asarray(a, float).ravel()
    b = np.asarray(b, float).ravel()
    if a.shape != b.shape or a.size < 2:
        raise ValueError("ratio_of_means needs two paired samples of equal length >= 2")
    ma, mb = a.mean(), b.mean()
    if mb == 0:
        raise ZeroDivisionError("mean of the denominator sample is zero")
    r = ma / mb
    c = np.cov(a, b, ddof=1)
    var = (c[0, 0] - 2 * r * c[0, 1] + r * r * c[1, 1]) / (mb * mb * a.size)
    return float(r), float(np.sqrt(max(var, 0.0)))


def bootstrap_median(d, n_boot: int, seed: int):
    """Median of the paired differences ``d`` (one per run), its bootstrap standard error and 95 %
    percentile interval: ``(median, se, lo, hi)``; ``n_boot`` resamples of the runs with a fixed seed
    (heavy tails cannot swamp a median the way they swamp a mean)."""
    d = np.asarray(d, float)
    rng = np.random.default_rng(seed)
    meds = np.median(d[rng.integers(0, d.size, size=(n_boot, d.size))], axis=1)
    lo, hi = np.percentile(meds, [2.5, 97.5])
    return float(np.median(d)), float(np.std(meds, ddof=1)), float(lo), float(hi)


def median_paired(a, b, n_boot: int, seed: int):
    """Median of the paired differences a - b over the runs where both are finite, and its
    bootstrap standard error (``n_boot`` resamples of the runs, fixed seed)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    ok = np.isfinite(a) & np.isfinite(b)
    med, se, _, _ = bootstrap_median(a[ok] - b[ok], n_boot, seed)
    return med, se


def std_difference(a, b, n_boot: int, seed: int):
    """Spread ordering: std(a) - std(b) over the runs where both are finite (sample std, ddof 1),
    with a paired bootstrap standard error (runs resampled together, fixed seed)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    ok = np.isfinite(a) & np.isfinite(b)
    a, b = a[ok], b[ok]
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, a.size, (n_boot, a.size))
    boot = np.std(a[idx], axis=1, ddof=1) - np.std(b[idx], axis=1, ddof=1)
    return float(np.std(a, ddof=1) - np.std(b, ddof=1)), float(np.std(boot, ddof=1))


def equivalence(diff, diff_se, margin, z=2.0):
    """Equivalence (two one-sided tests at the 2-SE level): True iff the interval
    ``diff ± z * diff_se`` lies inside ``(-margin, margin)``; False iff the interval lies
    wholly outside it (a difference larger than the margin); ``None`` otherwise."""
    lo, hi = diff - z * diff_se, diff + z * diff_se
    if -margin < lo and hi < margin:
        return True
    if lo >= margin or hi <= -margin:
        return False
    return None


def heavy_tailed(v, share: float) -> bool:
    """True if the largest absolute value carries more than ``share`` of the total (finite values)."""
    v = np.abs(np.asarray(v, float))
    v = v[np.isfinite(v)]
    return bool(v.size and v.sum() > 0 and v.max() > share * v.sum())


def p_two_sided(d: float, se: float) -> float:
    """Two-sided p-value of a paired mean difference ``d`` with standard error ``se`` (normal z test)."""
    if not (np.isfinite(d) and np.isfinite(se)):
        return float("nan")
    if se <= 0:
        return 0.0 if d != 0 else 1.0
    return float(math.erfc(abs(d / se) / math.sqrt(2.0)))


def holm(pvalues, alpha: float) -> np.ndarray:
    """Holm's step-down rule: which of the hypotheses with ``pvalues`` are rejected at family-wise
    error rate ``alpha``. Sorted p_(1) <= ... <= p_(m); reject while p_(i) <= alpha / (m - i + 1)
    (i = 1..m), stop at the first that is not. NaN p-values are never rejected (and count in m)."""
    p = np.asarray(pvalues, float)
    m = p.size
    reject = np.zeros(m, bool)
    order = np.argsort(np.where(np.isnan(p), np.inf, p), kind="stable")
    for i, idx in enumerate(order):
        if not (p[idx] <= alpha / (m - i)):
            break
        reject[idx] = True
    return reject


#: the one-sided normal quantile of the power every plan asks for (80 %)
Z_POWER = 0.8416212335729143


def plan_runs(sd_per_run: float, effect: float, z: float = 2.0, z_power: float = Z_POWER) -> int:
    """Runs a paired comparison needs so that a true mean difference of size ``effect`` is shown
    (``diff > z * se``) with 80 % power: ``ceil(((z + z_power) * sd_per_run / effect) ** 2)``, at least 2.

    ``sd_per_run`` is the standard deviation of the per-run differences (``se * sqrt(runs)`` of a
    pilot or of the main reading); ``effect`` the size to resolve (the paper's printed effect or the
    claim's smallest effect of interest), in the same units. Raises ``ValueError`` for a non-positive
    effect or a negative / non-finite spread.
    """
    sd_per_run, effect = float(sd_per_run), float(effect)
    if not (math.isfinite(effect) and effect > 0):
        raise ValueError(f"plan_runs needs an effect > 0, got {effect!r}")
    if not (math.isfinite(sd_per_run) and sd_per_run >= 0):
        raise ValueError(f"plan_runs needs a finite per-run sd >= 0, got {sd_per_run!r}")
    return max(2, int(math.ceil(((z + z_power) * sd_per_run / effect) ** 2)))
