"""A scripted stand-in for :class:`pfrepro.rng.RunStreams`, shared by the inner-step tests:
every draw returns the next array of a script, with its method and shape checked, so a test
pins both the numbers a filter draws and the order in which it draws them."""
from __future__ import annotations

import numpy as np

from pfrepro.rng import RunStreams


class ScriptedStreams(RunStreams):
    """A RunStreams whose draws are scripted: each ``random``/``standard_normal`` call returns
    the next ``(method, array)`` of the shared ``script`` (method and shape checked); ``subset``
    logs the selected runs and returns a child that reads the same script."""

    def __init__(self, runs, script, log=None):
        super().__init__([np.random.default_rng(0)] * runs)
        self.script = script
        self.log = [] if log is None else log

    def subset(self, sel):
        idx = np.flatnonzero(sel) if np.asarray(sel).dtype == bool else np.asarray(sel).ravel()
        self.log.append(("subset", idx.tolist()))
        return ScriptedStreams(len(idx), self.script, self.log)

    def _next(self, method, size):
        assert self.script, f"unscripted draw {method}{size}"
        m, a = self.script.pop(0)
        a = np.asarray(a, dtype=float)
        assert (m, a.shape) == (method, tuple(size)), f"draw {method}{tuple(size)}, script has {m}{a.shape}"
        self.log.append((method, tuple(size)))
        return a.copy()

    def random(self, size=None, dtype=np.float64):
        return self._next("random", size)

    def standard_normal(self, size=None, dtype=np.float64):
        return self._next("standard_normal", size)
