"""Result types shared by the filters and the Monte Carlo runner.

:class:`FilterResult` is what every filter's ``filter(y, rng)`` returns and what
:mod:`pfrepro.montecarlo` collects, concatenates across process-pool chunks and exports. It
lives below both (this module imports neither), so neither reaches into the other for it;
``pfrepro.filters`` and ``pfrepro.filters.base`` re-export it under its old names.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["FilterResult"]


@dataclass
class FilterResult:
    """Filtered estimates for ``runs`` runs of ``T`` steps.

    Attributes
    ----------
    x : ndarray
        Posterior means E[x_k | y_1:k], shape (runs, T, dim_x); ``x[:, k - 1]`` estimates x_k.
    P : ndarray or None
        Posterior covariances (runs, T, dim_x, dim_x), where the filter provides them.
    diagnostics : dict
        Filter-specific extras (effective sample sizes, resampling flags,
        collapse counts, lost grid mass, ...).
    """

    x: np.ndarray
    P: np.ndarray | None = None
    diagnostics: dict = field(default_factory=dict)

    @property
    def runs(self) -> int:
        """Number of Monte Carlo runs."""
        return self.x.shape[0]

    # -- exports (pfrepro.export) ----------------------------------------------------------
    def to_frame(self, truth=None, component_names=None):
        """Tidy ``pandas.DataFrame``: one row per (run, k, component); see
        :func:`pfrepro.export.filter_result_frame`."""
        from .export import filter_result_frame

        return filter_result_frame(self, truth, component_names)

    def to_csv(self, path, truth=None, component_names=None):
        """Write :meth:`to_frame` to ``path`` as CSV; returns the path."""
        from .export import write_table

        return write_table(self.to_frame(truth, component_names), path)
