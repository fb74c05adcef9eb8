"""State-space model interface shared by every model and filter, and the model contract.

A model describes

    x_k = f(x_{k-1}, k) + w_{k-1},    w ~ process_noise   (covariance Q, may be singular or 0)
    y_k = h(x_k) + v_k,               v ~ measurement_noise (covariance R)

for k = 1..T, with the truth starting at ``x0`` and the filters starting from
``N(m0, P0)``. Everything is vectorised over arbitrary leading axes: a state
array has shape ``(..., dim_x)``, so the same ``f`` serves a single state, a
batch of runs ``(runs, dim_x)`` or a particle cloud ``(runs, N, dim_x)``.

This follows the separation used by N. Chopin's ``particles`` package: the
model knows how to simulate and evaluate densities; filters know nothing about
a particular model beyond this interface.

Model contract
--------------
Which parts of a model each filter uses. A filter checks its needs when it is
built and raises :class:`ModelContractError` (a ``TypeError``) naming the filter,
the model and the missing capability, instead of running on placeholders.
Whether ``f``, ``h`` or a Jacobian exists is decided by whether the model's class
*overrides* the base-class method (the methods are never called to find out).

=====================  ============================================================
filter                 model methods / attributes it calls
=====================  ============================================================
KalmanFilter           ``F``, ``H`` (matrices), ``Q``, ``R``; additive measurement noise
ExtendedKalmanFilter   ``f``, ``jacobian_f``, ``h``, ``jacobian_h``, ``residual_y``,
(and variants)         ``Q``, ``R``; additive measurement noise
UnscentedKalmanFilter  ``f``, ``h``, ``residual_y``, ``Q``, ``R``; additive measurement noise
GaussianParticleFlow-  ``sample_transition`` (hence ``f`` and the process noise),
Filter                 ``h``, ``residual_y``, ``R``; additive measurement noise;
                       ``integrator="exact"`` also ``H``
BootstrapParticle-     ``sample_transition``, ``log_likelihood`` only
Filter
CMSParticleFilter      ``sample_transition``, ``log_likelihood`` only
EvolutionSampling-     ``f``, ``Q`` (Gaussian, positive definite: it evaluates the
ParticleFilter         transition density), ``log_likelihood``
GridFilter             ``dim_x == 1``, ``f``, a transition *density* (Gaussian process
                       noise with non-singular ``Q``), ``log_likelihood``
=====================  ============================================================

Every filter also reads ``dim_x``, ``dim_y``, ``m0`` and ``P0`` (its prior, unless
overridden). ``simulate`` uses ``x0``/``truth_init``, ``sample_transition`` and
``sample_measurement``.

Models whose measurement is not ``y = h(x) + v``
    set the class attribute ``additive_measurement_noise = False`` and override
    :meth:`~pfrepro.models.StateSpaceModel.log_likelihood` (the density p(y | x)) and
    :meth:`~pfrepro.models.StateSpaceModel.sample_measurement` (a draw y ~ p(y | x), which
    :meth:`~pfrepro.models.StateSpaceModel.simulate` calls). ``measurement_noise`` then describes
    the model's own noise variable (e.g. the e of y = exp(x/2) e) and ``h``/``R``
    mean nothing to a Gaussian filter, so KF/EKF/UKF/GPFF refuse the model while
    the particle filters and the grid filter accept it. See
    :class:`pfrepro.models.StochasticVolatility` for a complete example.

Models whose transition is not ``f(x) + w``
    override :meth:`~pfrepro.models.StateSpaceModel.sample_transition` (a particle filter then
    needs nothing else); do not override ``f`` unless it is the transition mean
    a Gaussian filter may use.

Output shapes (checked at the first call)
    A model's own ``f``, ``h``, ``jacobian_f``, ``jacobian_h``, ``sample_transition``,
    ``sample_measurement``, ``log_likelihood`` and ``residual_y`` are checked the first
    time each is called with an input of a given number of axes (a batch of runs, a
    particle cloud, sigma points): ``f`` and ``sample_transition`` return ``x.shape``; ``h``
    and ``sample_measurement`` ``x.shape[:-1] + (dim_y,)``; ``jacobian_f``
    ``x.shape[:-1] + (dim_x, dim_x)`` and ``jacobian_h`` ``x.shape[:-1] + (dim_y, dim_x)``
    (or one matrix for every state); ``log_likelihood(y, x)`` ``x.shape[:-1]``; and
    ``residual_y(y, y_pred)`` the broadcast shape of its inputs. A method returning one
    value for the whole batch, or another shape, raises :class:`ModelContractError` naming
    the method, the shape it returned and the shape expected, instead of being broadcast
    silently into wrong numbers or failing later in a numpy error. Later calls with inputs
    of the same number of axes are not checked again (the check costs nothing in a loop).

Singular and zero process noise
    ``Q`` may be positive *semi*-definite (``Q = G Qc G^T`` of lower rank) or zero
    (deterministic dynamics, no draw at all). Simulation, the KF/EKF/UKF, the
    bootstrap PF, CMS-PF and GPFF accept it; the grid filter and ESPF need a
    transition density and refuse it.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ..noise import GaussianNoise
from ..rng import check_rng
from ..validation import as_covariance, as_vector, check_memory, check_positive_int

__all__ = ["StateSpaceModel", "Simulation", "ModelContractError", "CAPABILITIES", "has_capability",
           "missing_capabilities", "require_capabilities", "batch_matmul", "draw_noise",
           "check_log_likelihood"]


class ModelContractError(TypeError):
    """A filter was given a model that lacks something the filter needs (see the module docstring)."""


@dataclass(frozen=True)
class Simulation:
    """Simulated truth and measurements for ``runs`` independent runs.

    Attributes
    ----------
    x : ndarray
        True states, shape (runs, T + 1, dim_x); ``x[:, 0]`` is the initial state x_0,
        ``x[:, k]`` is x_k.
    y : ndarray
        Measurements, shape (runs, T, dim_y); ``y[:, k - 1]`` is y_k.
    """

    x: np.ndarray
    y: np.ndarray

    @property
    def runs(self) -> int:
        """Number of runs."""
        return self.x.shape[0]

    @property
    def T(self) -> int:
        """Number of time steps (measurements per run)."""
        return self.y.shape[1]

    def run(self, i: int) -> "Simulation":
        """The i-th run as a one-run simulation (keeps the leading axis)."""
        return Simulation(self.x[i : i + 1], self.y[i : i + 1])


def init_noise_and_prior(model, dim_x, dim_y, Q, measurement_noise, x0, m0, P0, truth_init="fixed") -> None:
    """Validate and set what every model has: ``dim_x``, ``dim_y``, ``process_noise`` (Q,
    possibly singular or zero), ``measurement_noise`` (a noise object with ``logpdf``, or a
    covariance R), the truth's ``x0``, the filters' prior ``N(m0, P0)`` and ``truth_init``.
    Shared by :class:`StateSpaceModel` and the θ-parameterised models
    (:class:`pfrepro.models.parameterized.ParameterizedModel`)."""
    model.dim_x = check_positive_int(dim_x, "dim_x")
    model.dim_y = check_positive_int(dim_y, "dim_y")
    # Q may be singular (Q = G Qc G^T of lower rank) or zero (deterministic dynamics)
    model.process_noise = GaussianNoise(as_covariance(Q, "Q", model.dim_x, allow_singular=True),
                                        allow_singular=True)
    if not hasattr(measurement_noise, "logpdf"):
        measurement_noise = GaussianNoise(as_covariance(measurement_noise, "R", model.dim_y))
    if measurement_noise.dim != model.dim_y:
        raise ValueError(f"measurement noise has dimension {measurement_noise.dim}, model has dim_y = {model.dim_y}")
    model.measurement_noise = measurement_noise
    model.x0 = as_vector(x0, "x0", model.dim_x)
    model.m0 = as_vector(m0, "m0", model.dim_x)
    model.P0 = as_covariance(P0, "P0", model.dim_x)
    if truth_init not in ("fixed", "prior"):
        raise ValueError("truth_init must be 'fixed' or 'prior'")
    model.truth_init = truth_init


def _residual_shape(m, args, kwargs):
    y = args[0] if args else kwargs.get("y")
    yp = args[1] if len(args) > 1 else kwargs.get("y_pred")
    try:
        return np.broadcast_shapes(np.shape(y), np.shape(yp)), "the broadcast shape of y and y_pred"
    except ValueError:
        return None, ""


def _batch(i, key):
    def get(args, kwargs):
        return args[i] if len(args) > i else kwargs.get(key)
    return get


#: the model methods whose output shape the contract checks: name -> (how to find the batch
#: argument ``x`` among the call's arguments, expected shape and its rule from (model, x.shape))
_SHAPE_RULES = {
    "f": (_batch(0, "x"), lambda m, s: (s, "x.shape")),
    "sample_transition": (_batch(0, "x"), lambda m, s: (s, "x.shape")),
    "h": (_batch(0, "x"), lambda m, s: (s[:-1] + (m.dim_y,), "x.shape[:-1] + (dim_y,)")),
    "sample_measurement": (_batch(0, "x"), lambda m, s: (s[:-1] + (m.dim_y,), "x.shape[:-1] + (dim_y,)")),
    "jacobian_f": (_batch(0, "x"), lambda m, s: (s[:-1] + (m.dim_x, m.dim_x), "x.shape[:-1] + (dim_x, dim_x)")),
    "jacobian_h": (_batch(0, "x"), lambda m, s: (s[:-1] + (m.dim_y, m.dim_x), "x.shape[:-1] + (dim_y, dim_x)")),
    "log_likelihood": (_batch(1, "x"), lambda m, s: (s[:-1], "x.shape[:-1], one value per state")),
}
#: a Jacobian may also be one matrix shared by every state (a linear model's F or H)
_SHARED_OK = {"jacobian_f", "jacobian_h"}


def _expected_shape(model, method, args, kwargs):
    """(expected output shape, rule text, the batch argument's shape) of ``method``'s call."""
    if method == "residual_y":
        shape, rule = _residual_shape(model, args, kwargs)
        return shape, rule, None
    get, rule = _SHAPE_RULES[method]
    x = get(args, kwargs)
    if x is None:
        return None, "", None
    s = np.shape(x)
    if len(s) == 0:
        return None, "", s
    shape, text = rule(model, s)
    return shape, text, s


def _check_output(model, method, args, kwargs, out):
    shape, rule, xs = _expected_shape(model, method, args, kwargs)
    if shape is None:
        return
    got = np.shape(out)
    if got == shape or (method in _SHARED_OK and got == shape[-2:]):
        return
    given = "" if xs is None else f" for x of shape {xs}"
    hint = " (one value for the whole batch: vectorise over the leading axes)" if np.prod(got, dtype=int) < np.prod(
        shape, dtype=int) and len(got) < len(shape) else ""
    raise ModelContractError(
        f"{type(model).__name__}.{method} returned shape {got}{given}; the model contract expects {shape} "
        f"({rule}){hint}. See the model contract in pfrepro.models.base")


def check_log_likelihood(model, y, x, out):
    """A log-likelihood is a number or -inf for every finite state: NaN where ``x`` and ``y`` are
    finite (e.g. the log of a negative intensity, 0 * inf) raises ``ValueError`` naming the
    model, the runs and a state, instead of becoming a zero weight in silence.

    One pass over ``out`` (its sum is NaN only if an entry is NaN, or +inf meets -inf); the
    entries are searched only then."""
    out = np.asarray(out)
    if out.dtype.kind != "f" or not np.isnan(out.sum()):
        return
    nan = np.isnan(out)
    xa = np.asarray(x, dtype=float)
    finite_x = np.isfinite(xa).all(axis=-1) if xa.ndim else np.isfinite(xa)
    try:
        nan &= np.broadcast_to(finite_x, nan.shape)
    except ValueError:
        pass
    if not nan.any():
        return                     # NaN only at non-finite states (a run already lost): not the model's fault
    where = np.argwhere(nan)
    first = tuple(int(i) for i in where[0])
    runs = np.unique(where[:, 0]).tolist() if nan.ndim > 1 else []
    state = xa[first] if xa.ndim > 1 and xa.shape[:-1] == nan.shape else None
    raise ValueError(
        f"{type(model).__name__}.log_likelihood returned NaN for {int(nan.sum())} finite state(s)"
        + (f" in runs {runs[:10]}{' ...' if len(runs) > 10 else ''}" if runs else "")
        + (f" (first at index {first}, x = {np.array2string(state, precision=6)})" if state is not None else "")
        + "; a log-density must be a number or -inf (a zero density). A filter would have given those "
          "states zero weight in silence: fix the model where it returns NaN")


def _contract_checked(method, fn):
    """``fn`` with its output shape checked at the first call per number of input axes."""
    if getattr(fn, "_contract_checked", False):
        return fn

    @functools.wraps(fn)
    def checked(self, *args, **kwargs):
        out = fn(self, *args, **kwargs)
        if method == "log_likelihood":         # NaN is checked at every call (one pass)
            check_log_likelihood(self, args[0] if args else kwargs.get("y"), _SHAPE_RULES[method][0](args, kwargs), out)
        if method == "residual_y":
            key = (method, np.ndim(args[0] if args else kwargs.get("y")),
                   np.ndim(args[1] if len(args) > 1 else kwargs.get("y_pred")))
        else:
            key = (method, np.ndim(_SHAPE_RULES[method][0](args, kwargs)))
        seen = getattr(self, "__dict__", {}).get("_contract_seen")
        if seen is None or key not in seen:
            _check_output(self, method, args, kwargs, out)
            try:
                self.__dict__.setdefault("_contract_seen", set()).add(key)
            except AttributeError:    # no instance dict (__slots__): check every call
                pass
        return out

    checked._contract_checked = True
    return checked


class StateSpaceModel:
    """Additive-Gaussian-process-noise state-space model (see module docstring).

    Subclasses implement :meth:`f`, :meth:`h` and their Jacobians
    :meth:`jacobian_f`, :meth:`jacobian_h`. Angles and other wrapped
    measurements override :meth:`residual_y`.

    Parameters
    ----------
    Q : ndarray
        ``(dim_x, dim_x)`` process-noise covariance.
    measurement_noise : GaussianNoise, GaussianMixtureNoise or ndarray
        A ``GaussianNoise``/``GaussianMixtureNoise`` or a
        covariance matrix (read as zero-mean Gaussian).
    x0 : ndarray
        True initial state.
    m0, P0 : ndarray
        The filters' initial distribution N(m0, P0).
    truth_init : {"fixed", "prior"}
        ``"fixed"`` (every run starts at ``x0``) or ``"prior"``
        (each run draws x_0 ~ N(m0, P0)).
    """

    name = "state-space model"
    #: False for a model whose measurement is not y = h(x) + v; it then overrides
    #: ``log_likelihood`` and ``sample_measurement`` (see the module docstring).
    additive_measurement_noise = True

    def __init__(self, dim_x, dim_y, Q, measurement_noise, x0, m0, P0, truth_init="fixed"):
        init_noise_and_prior(self, dim_x, dim_y, Q, measurement_noise, x0, m0, P0, truth_init)

    def __init_subclass__(cls, **kwargs):
        # the model contract's output-shape check (module docstring): every method a model
        # class defines itself is wrapped once, at class creation
        super().__init_subclass__(**kwargs)
        for method in (*_SHAPE_RULES, "residual_y"):
            fn = cls.__dict__.get(method)
            if callable(fn) and not isinstance(fn, (staticmethod, classmethod)):
                setattr(cls, method, _contract_checked(method, fn))

    # -- covariances a Gaussian filter is given ------------------------------------
    @property
    def Q(self) -> np.ndarray:
        """Process-noise covariance (dim_x, dim_x)."""
        return self.process_noise.cov

    @property
    def R(self) -> np.ndarray:
        """Measurement-noise covariance (the mixture's own covariance for a mixture)."""
        return self.measurement_noise.cov

    # -- to be implemented by subclasses ------------------------------------------
    def f(self, x: np.ndarray, k: int) -> np.ndarray:
        """Noise-free transition: mean of x_k given x_{k-1} = x."""
        raise NotImplementedError

    def jacobian_f(self, x: np.ndarray, k: int) -> np.ndarray:
        """d f / d x at ``x``, shape ``(..., dim_x, dim_x)``."""
        raise NotImplementedError

    def h(self, x: np.ndarray) -> np.ndarray:
        """Noise-free measurement function."""
        raise NotImplementedError

    def jacobian_h(self, x: np.ndarray) -> np.ndarray:
        """d h / d x at ``x``, shape ``(..., dim_y, dim_x)``."""
        raise NotImplementedError

    def residual_y(self, y: np.ndarray, y_pred: np.ndarray) -> np.ndarray:
        """Innovation y - y_pred (overridden for wrapped quantities such as angles)."""
        return y - y_pred

    # -- derived ---------------------------------------------------------------------
    def sample_transition(self, x: np.ndarray, k: int, rng: np.random.Generator) -> np.ndarray:
        """Draw x_k ~ p(x_k | x_{k-1} = x) for every state in the batch ``x``."""
        out = draw_noise(self.process_noise, rng, x.shape[:-1])
        out += self.f(x, k)
        return out

    def log_likelihood(self, y: np.ndarray, x: np.ndarray) -> np.ndarray:
        """log p(y | x) for a batch: ``y`` (runs, dim_y), ``x`` (runs, ..., dim_x).

        ``y`` is broadcast over the particle axes of ``x``; returns ``x.shape[:-1]``.
        """
        y = np.asarray(y, dtype=float)
        y = y.reshape(y.shape[:1] + (1,) * (x.ndim - 2) + y.shape[1:])
        out = self.measurement_noise.logpdf(self.residual_y(y, self.h(x)))
        check_log_likelihood(self, y, x, out)
        return out

    def sample_initial(self, rng: np.random.Generator, shape) -> np.ndarray:
        """Draw from the filters' prior N(m0, P0); returns ``(*shape, dim_x)``."""
        shape = tuple(np.atleast_1d(shape))
        z = rng.standard_normal(shape + (self.dim_x,))
        return self.m0 + batch_matmul(z, np.linalg.cholesky(self.P0))

    def simulate(self, T: int, runs: int = 1, rng: np.random.Generator | None = None) -> Simulation:
        """Simulate ``runs`` independent trajectories of length ``T``.

        All runs advance together (one vectorised draw per time step), so the
        cost is T numpy calls regardless of ``runs``. The model's methods see each
        run's state as a cloud of one, shape ``(runs, 1, dim_x)``: a product such as
        ``x @ F.T`` is then one small product per run, whose last bits do not depend on
        how many runs the batch holds (a 2-D ``(runs, dim_x) @ F.T`` rounds a lone run
        differently), so a run's truth is the same serially and in a chunk of one run on
        a worker. The draws are those of ``(runs, dim_x)``: run i's stream is read in the
        same order.
        """
        T = check_positive_int(T, "T")
        runs = check_positive_int(runs, "runs")
        check_memory(8.0 * runs * ((T + 1) * self.dim_x + T * self.dim_y), f"{T} steps of simulated states and "
                     "measurements", "runs", runs)
        check_rng(rng)
        x = np.empty((runs, T + 1, self.dim_x))
        y = np.empty((runs, T, self.dim_y))
        x[:, 0] = self.x0 if self.truth_init == "fixed" else self.sample_initial(rng, runs)
        for k in range(1, T + 1):
            nxt = self.sample_transition(x[:, k - 1, None], k, rng)
            x[:, k] = nxt[:, 0]
            y[:, k - 1] = self.sample_measurement(nxt, rng)[:, 0]
            # a trajectory that leaves the numbers is an error here, at its step (a filter
            # would refuse the NaN measurements later, far from the cause)
            if not (np.isfinite(x[:, k]).all() and np.isfinite(y[:, k - 1]).all()):
                _non_finite_simulation(self, x, y, k)
        return Simulation(x=x, y=y)

    def sample_measurement(self, x: np.ndarray, rng) -> np.ndarray:
        """Draw y ~ p(y | x) for every state in the batch ``x`` (runs first); ``(..., dim_y)``.

        The default is ``h(x) + v``; a model with non-additive measurement noise
        overrides it (and :meth:`log_likelihood`). :meth:`~pfrepro.models.StateSpaceModel.simulate` calls it.
        """
        out = draw_noise(self.measurement_noise, rng, x.shape[:-1])
        out += self.h(x)
        return out

    # -- the contract ------------------------------------------------------------------
    def implements(self, method: str) -> bool:
        """True when the model's class overrides the base-class ``method`` (``"f"``, ``"h"``, ...)."""
        return getattr(type(self), method, None) is not getattr(StateSpaceModel, method, None)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(dim_x={self.dim_x}, dim_y={self.dim_y})"


def _non_finite_simulation(model, x, y, k):
    """Raise the error of :meth:`StateSpaceModel.simulate` for a non-finite state or measurement at step k."""
    bad_x = ~np.isfinite(x[:, k]).all(axis=-1)
    what, bad = ("state x_k", bad_x) if bad_x.any() else ("measurement y_k", ~np.isfinite(y[:, k - 1]).all(axis=-1))
    r = int(np.flatnonzero(bad)[0])
    raise FloatingPointError(
        f"{type(model).__name__}.simulate: the {what} became non-finite at step k = {k} in "
        f"{int(bad.sum())} of {x.shape[0]} runs (first run {r}: x_{k - 1} = "
        f"{np.array2string(x[r, k - 1], precision=6)}, x_k = {np.array2string(x[r, k], precision=6)}); "
        f"check f, the process noise and h there (an unstable model or a wrong formula)")


def _is_matrix(model, name):
    return isinstance(getattr(model, name, None), np.ndarray) and getattr(model, name).ndim == 2


def _has_density(model):
    noise = getattr(model, "process_noise", None)
    return isinstance(noise, GaussianNoise) and not noise.is_singular


def _density_lack(model):
    if not model.implements("f"):
        return "does not implement f"
    if not isinstance(getattr(model, "process_noise", None), GaussianNoise):
        return "has non-Gaussian process noise"
    lam = np.linalg.eigvalsh(model.Q).min()
    return (f"has a singular process-noise covariance Q (smallest eigenvalue {lam:.3g}), "
            "so x_k | x_k-1 has no density")


#: capability -> (test on the model, what a filter needs, what the model lacks (text or callable))
CAPABILITIES = {
    "f": (lambda m: m.implements("f"), "a transition mean f(x, k)", "does not implement f"),
    "jacobian_f": (lambda m: m.implements("jacobian_f"), "jacobian_f", "does not implement jacobian_f"),
    "h": (lambda m: m.implements("h"), "a measurement function h(x)", "does not implement h"),
    "jacobian_h": (lambda m: m.implements("jacobian_h"), "jacobian_h", "does not implement jacobian_h"),
    "additive_measurement": (
        lambda m: bool(getattr(m, "additive_measurement_noise", False)) and m.implements("h"),
        "additive measurement noise y = h(x) + v",
        lambda m: ("has non-additive measurement noise" if not getattr(m, "additive_measurement_noise", False)
                   else "does not implement h")),
    "linear": (lambda m: _is_matrix(m, "F") and _is_matrix(m, "H"),
               "linear dynamics and measurements (matrices F and H)", "has no matrices F and H"),
    "measurement_matrix": (lambda m: _is_matrix(m, "H"), "a measurement matrix H", "has no matrix H"),
    "transition_sampler": (lambda m: m.implements("f") or m.implements("sample_transition"),
                           "a transition sampler (f or sample_transition)",
                           "implements neither f nor sample_transition"),
    "likelihood": (lambda m: m.implements("log_likelihood")
                   or (bool(getattr(m, "additive_measurement_noise", False)) and m.implements("h")),
                   "a likelihood p(y | x) (log_likelihood, or h with additive noise)",
                   "has no log_likelihood"),
    "transition_density": (lambda m: m.implements("f") and _has_density(m),
                           "a transition density (f and Gaussian process noise with non-singular Q)",
                           lambda m: _density_lack(m)),
    "scalar_state": (lambda m: m.dim_x == 1, "a scalar state (dim_x == 1)", "has dim_x != 1"),
}


def has_capability(model, capability: str) -> bool:
    """Whether ``model`` provides ``capability`` (a key of :data:`CAPABILITIES`)."""
    if capability not in CAPABILITIES:
        raise ValueError(f"unknown model capability {capability!r}; choose from {sorted(CAPABILITIES)}")
    return bool(CAPABILITIES[capability][0](model))


def missing_capabilities(model, capabilities) -> list:
    """The subset of ``capabilities`` that ``model`` lacks, in the order given."""
    return [c for c in capabilities if not has_capability(model, c)]


def require_capabilities(model, capabilities, who: str) -> None:
    """Raise :class:`ModelContractError` unless ``model`` has every capability.

    The message names ``who`` (the filter), what it needs, the model, and what
    the model lacks, e.g. "ExtendedKalmanFilter needs a model with additive
    measurement noise y = h(x) + v and jacobian_h; StochasticVolatility has
    non-additive measurement noise".
    """
    if not isinstance(model, StateSpaceModel):
        # duck-typed models (test doubles, a reader's own minimal class) are taken on trust:
        # which methods a plain object "implements" cannot be told from a base class, so the
        # filter calls what it needs and an AttributeError names what is missing
        return
    missing = missing_capabilities(model, capabilities)
    if missing:
        needs = [CAPABILITIES[c][1] for c in capabilities]
        lacks = [CAPABILITIES[c][2] for c in missing]
        lacks = [t(model) if callable(t) else t for t in lacks]
        if model.dim_x != 1 and "scalar_state" in missing:
            lacks[missing.index("scalar_state")] = f"has dim_x = {model.dim_x}"
        need_txt = needs[0] if len(needs) == 1 else ", ".join(needs[:-1]) + " and " + needs[-1]
        raise ModelContractError(f"{who} needs a model with {need_txt}; "
                                 f"{type(model).__name__} {'; it '.join(lacks)}")


# -- arithmetic that does not depend on the batch -----------------------------------------------
def batch_matmul(x, A) -> np.ndarray:
    """``x @ A.T`` for states ``x`` of shape ``(..., n)``, each state's result independent of the batch.

    A 2-D product ``(runs, n) @ (n, m)`` is one BLAS call whose rounding of a row depends on
    the number of rows (a lone row takes a matrix-vector path): run i's numbers would then
    differ in the last bits between a serial call and a chunk of one run on a worker
    (``run_monte_carlo`` with an executor). For a 2-D ``x`` the product is therefore an
    explicit sum over the small dimension ``n`` (``x[:, 0] A[:, 0] + x[:, 1] A[:, 1] + ...``,
    elementwise, in that order). With three or more axes, ``x @ A.T`` is already one product
    per leading index (a run's cloud) of a fixed shape, and is kept (one BLAS call per run is
    much faster than the sum on large clouds); a single state (1-D) is ``x @ A.T``.

    Parameters
    ----------
    x : ndarray
        States, shape ``(..., n)``.
    A : ndarray
        Matrix of shape ``(m, n)``.

    Returns
    -------
    ndarray
        Shape ``x.shape[:-1] + (m,)``.
    """
    x = np.asarray(x)
    A = np.asarray(A)
    if x.ndim != 2:
        return x @ A.T
    if A.ndim != 2 or A.shape[1] != x.shape[1]:
        raise ValueError(f"batch_matmul: x has shape {x.shape} and A shape {A.shape}; A must be (m, {x.shape[1]})")
    out = x[:, :1] * A[:, 0]
    for j in range(1, A.shape[1]):
        out += x[:, j:j + 1] * A[:, j]
    return out


def draw_noise(noise, rng, shape) -> np.ndarray:
    """``noise.sample(rng, shape)`` whose result for a run does not depend on the batch.

    With one state per run (``shape`` ``(runs,)`` or ``(runs, 1, ...)``: a truth being
    simulated, a Kalman-type filter's batch), a multivariate Gaussian's ``L z`` is a
    :func:`batch_matmul` instead of the noise's one tall 2-D product (which rounds a lone
    run differently); the standard normals drawn are the same. Particle clouds (more than
    one state per run), scalar noise and mixtures (drawn run by run) use ``noise.sample``
    unchanged.
    """
    if type(shape) is not tuple:
        shape = tuple(np.atleast_1d(shape))
    if (isinstance(noise, GaussianNoise) and noise.dim > 1 and not noise.is_zero and len(shape) >= 1
            and int(np.prod(shape[1:], dtype=np.int64)) == 1):
        z = rng.standard_normal(shape + (noise.dim,))
        out = batch_matmul(z.reshape(shape[0], noise.dim), noise._chol)
        if np.any(noise.mean):
            out += noise.mean
        return out.reshape(shape + (noise.dim,))
    return noise.sample(rng, shape)
