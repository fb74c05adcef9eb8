"""Run-by-run identity: a run's numbers do not depend on the batch it is filtered in.

Every particle filter of the package draws from per-run streams (:class:`pfrepro.rng.RunStreams`),
so run r of a batch of 8 must be bit-identical to the same run filtered alone and in a batch of 3.
Draws are not the only way a batch can leak into a run: a matrix product over a 2-D array of
shape (runs, n) rounds differently when it has one row (BLAS takes a matrix-vector kernel) than
when it has several; a product over (runs * N, n) can round differently with the number of rows.
The model here is 4-D (constant-velocity planar tracking, position measured), where such products
have several terms and their rounding shows; a scalar model cannot show it.
"""
import numpy as np
import pytest

from pfrepro.filters import BootstrapParticleFilter
from pfrepro.filters.auxiliary import AuxiliaryParticleFilter
from pfrepro.filters.gaussian_proposal import GaussianProposalParticleFilter
from pfrepro.filters.jump_markov_pf import JumpMarkovParticleFilter
from pfrepro.filters.pfpf import ParticleFlowParticleFilter
from pfrepro.filters.regularized import RegularizedParticleFilter
from pfrepro.filters.smc2 import SMC2
from pfrepro.models import LinearGaussianModel
from pfrepro.models.jump_markov import JumpMarkovSystem
from pfrepro.models.parameterized import ParameterizedModel
from pfrepro.montecarlo import filter_streams, truth_streams

DT = 0.7
OMEGA = 0.15          # a gentle known turn rate: every entry of F is a rounded product (a CV model's 0s
#                       and 1s would make the products exact and hide the rounding)
F_CV = np.array([[1.0, 0, np.sin(OMEGA * DT) / OMEGA, -(1 - np.cos(OMEGA * DT)) / OMEGA],
                 [0, 1, (1 - np.cos(OMEGA * DT)) / OMEGA, np.sin(OMEGA * DT) / OMEGA],
                 [0, 0, np.cos(OMEGA * DT), -np.sin(OMEGA * DT)],
                 [0, 0, np.sin(OMEGA * DT), np.cos(OMEGA * DT)]])
Q_CV = 0.05 * np.array([[DT ** 3 / 3, 0, DT ** 2 / 2, 0], [0, DT ** 3 / 3, 0, DT ** 2 / 2],
                        [DT ** 2 / 2, 0, DT, 0], [0, DT ** 2 / 2, 0, DT]])
SENSOR = 0.4          # the sensor's axes are rotated against the state's: H mixes both coordinates
H_POS = np.array([[np.cos(SENSOR), np.sin(SENSOR), 0, 0], [-np.sin(SENSOR), np.cos(SENSOR), 0, 0]])
R_POS = np.array([[0.5, 0.1], [0.1, 0.4]])
X0 = np.array([0.0, 0.0, 1.0, 0.5])
P0 = np.diag([1.0, 1.0, 0.3, 0.3])


def cv_model(turn=0.0):
    """4-D planar tracking model, nearly constant velocity with a known turn (``turn`` radians a
    step more for the jump-Markov modes): the package's own :class:`LinearGaussianModel`, whose f
    and h are matrix products over the particle array."""
    F = F_CV.copy()
    c, s = np.cos(turn), np.sin(turn)
    F[2:] = np.array([[c, -s], [s, c]]) @ F[2:]
    return LinearGaussianModel(F, H_POS, Q_CV, R_POS, X0, P0=P0)


class DampedCV(ParameterizedModel):
    """The 4-D constant-velocity model with an unknown velocity damping θ (for SMC²)."""

    def __init__(self):
        super().__init__(4, 2, 1, Q_CV, R_POS, X0, X0, P0, [0.9], (0.5, 1.0))

    def f(self, x, k, theta):
        out = x.copy()
        out[..., :2] += DT * x[..., 2:]
        out[..., 2:] *= theta            # theta (..., 1) broadcasts against the velocity
        return out

    def jacobian_f(self, x, k, theta):
        raise NotImplementedError

    def jacobian_f_theta(self, x, k, theta):
        raise NotImplementedError

    def h(self, x):
        return np.cos(SENSOR) * x[..., :2] + np.sin(SENSOR) * np.stack([x[..., 1], -x[..., 0]], axis=-1)

    def jacobian_h(self, x):
        return np.broadcast_to(H_POS, x.shape[:-1] + H_POS.shape)


def _jm_system():
    return JumpMarkovSystem([cv_model(0.0), cv_model(0.3), cv_model(-0.3)],
                            np.array([[0.9, 0.05, 0.05], [0.1, 0.85, 0.05], [0.1, 0.05, 0.85]]))


FILTERS = {
    "PF": (cv_model, lambda m: BootstrapParticleFilter(m, 64)),
    "PF-ess": (cv_model, lambda m: BootstrapParticleFilter(m, 64, ess_threshold=0.5)),
    "APF": (cv_model, lambda m: AuxiliaryParticleFilter(m, 64)),
    "RPF": (cv_model, lambda m: RegularizedParticleFilter(m, 64, ess_threshold=0.5)),
    "EKF-proposal PF": (cv_model, lambda m: GaussianProposalParticleFilter(m, 64)),
    "UT-proposal PF": (cv_model, lambda m: GaussianProposalParticleFilter(m, 64, proposal="unscented",
                                                                            ess_threshold=0.5)),
    "PFPF(EDH)": (cv_model, lambda m: ParticleFlowParticleFilter(m, 64, flow="edh", ess_threshold=0.5)),
    "PFPF(LEDH)": (cv_model, lambda m: ParticleFlowParticleFilter(m, 16, flow="ledh", n_steps=8)),
    "JMPF": (_jm_system, lambda s: JumpMarkovParticleFilter(s, 64, ess_threshold=0.5)),
    "SMC2": (DampedCV, lambda m: SMC2(m, 8, 16)),
}

T, BIG = 12, 8


def _outputs(res):
    d = res.diagnostics
    out = {"x": res.x, "log_evidence": d["log_evidence"]}
    for key in ("log_det", "mode_probs", "theta", "ess", "theta_ess"):
        if key in d:
            out[key] = d[key]
    return out


@pytest.mark.parametrize("name", list(FILTERS))
def test_run_is_the_same_in_any_batch(name):
    make_model, make_filter = FILTERS[name]
    model = make_model()
    y = model.simulate(T, BIG, truth_streams(11, BIG)).y
    filt = make_filter(model)
    seed = 5
    full = _outputs(filt.filter(y, filter_streams(seed, name, BIG)))
    # batches of 3 (runs 2-4) and of 1 (runs 0 and 6), each drawing from those runs' own streams
    for start, size in ((2, 3), (0, 1), (6, 1), (5, 3)):
        part = _outputs(filt.filter(y[start:start + size], filter_streams(seed, name, size, start=start)))
        for key, v in full.items():
            a, b = v[start:start + size], part[key]
            assert np.array_equal(a, b, equal_nan=True), (
                f"{name}: {key} of runs {start}..{start + size - 1} differ between a batch of {BIG} and one "
                f"of {size} (max abs difference {np.nanmax(np.abs(a - b)):.3g})")


@pytest.mark.parametrize("name", ["KF", "EKF", "UKF"])
def test_kalman_family_run_is_the_same_in_any_batch(name):
    """The Kalman family too: its mean is a product over a (runs, n) array, which rounds a lone
    run differently unless written per run (the command line's chunks of one run)."""
    from pfrepro.filters import ExtendedKalmanFilter, KalmanFilter, UnscentedKalmanFilter

    model = cv_model()
    y = model.simulate(T, BIG, truth_streams(11, BIG)).y
    filt = {"KF": KalmanFilter, "EKF": ExtendedKalmanFilter, "UKF": UnscentedKalmanFilter}[name](model)
    full = filt.filter(y)
    for start, size in ((2, 3), (0, 1), (6, 1)):
        part = filt.filter(y[start:start + size])
        for key in ("x", "P"):
            a, b = getattr(full, key)[start:start + size], getattr(part, key)
            assert np.array_equal(a, b), f"{name}: {key} of runs {start}.. differ (max {np.max(np.abs(a - b)):.3g})"
