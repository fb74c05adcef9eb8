"""Manoeuvring-target models on the 6-D state [Rx, Vx, ax, Ry, Vy, ay] (Zhou et al. 2017, sec 3).

Zhou et al. use constant-velocity (CV), coordinated-turn (CT) and constant-acceleration
(CA) models on x = [Rx, Vx, ax, Ry, Vy, ay] and measure range, Doppler (range rate)
and bearing. Their matrices were lost from our copy of the paper; these are the
textbook forms (Bar-Shalom, Li & Kirubarajan 2001, sec 6.3 and 11.7; Li & Jilkov 2003),
written per axis (position, velocity, acceleration) and stacked block-diagonally:

* **CV** (``cv_axis``): [[1, T, 0], [0, 1, 0], [0, 0, 0]] -- position and velocity as in
  the 4-D nearly-constant-velocity model; the acceleration component is *reset to 0*
  (the usual way to embed CV in a state that carries acceleration, so that a CV-mode
  particle or estimate has no acceleration). Noise gain G = [T^2/2, T, 0]^T
  (discrete white-noise acceleration, DWNA).
* **CA** (``ca_axis``): [[1, T, T^2/2], [0, 1, T], [0, 0, 1]], G = [T^2/2, T, 1]^T
  (discrete Wiener-process acceleration, DWPA).
* **CT, per axis** (``ct_axis``), turn rate w, s = sin wT, c = cos wT:
  [[1, s/w, (1-c)/w^2], [0, c, s/w], [0, -w s, c]], G = [T^2/2, T, 1]^T.
  This is the exact discretisation of  d(pos) = vel, d(vel) = acc, d(acc) = -w^2 vel
  on each axis. A coordinated turn at rate +w *or* -w with the centripetal acceleration
  a = w J v (J the 90-degree rotation) satisfies exactly this equation, so one
  per-axis CT model follows left and right turns of rate ``|w|`` once its acceleration
  state holds the centripetal acceleration (checked in ``tests/test_imm_models.py``).
  It is the form found in Chinese IMM code for this 6-D state; it keeps the model
  block-diagonal, as the state ordering [Rx, Vx, ax, Ry, Vy, ay] suggests.
* **Coupled CT** (``coupled_ct_matrix``, used for the *truth*): the standard coordinated
  turn on (Rx, Vx, Ry, Vy) (Bar-Shalom et al. 2001, eq 11.7.1-4) with the acceleration
  components set to the centripetal acceleration of the new velocity,
  ax = -w Vy, ay = w Vx. Positive w turns left (counter-clockwise).

Process noise is Q = G Qc G^T per axis with Qc = q (a variance), block-diagonal over the
two axes; it is singular (rank 2) by construction, which the package accepts.

Measurement (radar at the origin): range r = sqrt(Rx^2 + Ry^2), Doppler (range rate)
(Rx Vx + Ry Vy) / r and bearing atan2(Ry, Rx); the bearing innovation is wrapped to
(-pi, pi] in :meth:`~pfrepro.models.RadarTrackingModel.residual_y`.
"""
from __future__ import annotations

import numpy as np

from .base import StateSpaceModel, batch_matmul
from .bot import wrap_angle

__all__ = ["cv_axis", "ca_axis", "ct_axis", "block_diag_axes", "coupled_ct_matrix", "process_noise_Q",
           "RadarTrackingModel", "cv_model", "ca_model", "ct_model", "coupled_ct_model", "IDX_POS", "IDX_VEL",
           "radar_h", "radar_jacobian"]

#: indices of (Rx, Ry) and (Vx, Vy) in the 6-D state
IDX_POS = (0, 3)
IDX_VEL = (1, 4)


def cv_axis(T: float):
    """(F, G) of the CV model on one axis (position, velocity, acceleration reset to 0)."""
    return np.array([[1.0, T, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]]), np.array([T * T / 2, T, 0.0])


def ca_axis(T: float):
    """(F, G) of the CA model on one axis (DWPA)."""
    return np.array([[1.0, T, T * T / 2], [0.0, 1.0, T], [0.0, 0.0, 1.0]]), np.array([T * T / 2, T, 1.0])


def ct_axis(T: float, w: float):
    """(F, G) of the per-axis coordinated-turn model with turn rate ``w`` (rad/s), see module docstring."""
    if w == 0:
        raise ValueError("ct_axis needs a non-zero turn rate w (w -> 0 is the CA model)")
    s, c = np.sin(w * T), np.cos(w * T)
    F = np.array([[1.0, s / w, (1 - c) / w ** 2], [0.0, c, s / w], [0.0, -w * s, c]])
    return F, np.array([T * T / 2, T, 1.0])


def block_diag_axes(A):
    """Stack a per-axis 3x3 matrix into the 6x6 block-diagonal matrix for [x-axis, y-axis]."""
    out = np.zeros((6, 6))
    out[:3, :3] = A
    out[3:, 3:] = A
    return out


def process_noise_Q(G, q: float):
    """Q = G q G^T per axis, stacked over the two axes (rank 2 for a 3-vector G)."""
    if q < 0:
        raise ValueError(f"process-noise variance q must be >= 0, got {q}")
    G = np.asarray(G, float)
    return block_diag_axes(q * np.outer(G, G))


def coupled_ct_matrix(T: float, w: float):
    """6x6 transition of the exact coordinated turn (rate ``w``, left for w > 0), acceleration centripetal."""
    if w == 0:
        raise ValueError("coupled_ct_matrix needs a non-zero turn rate")
    s, c = np.sin(w * T), np.cos(w * T)
    F = np.zeros((6, 6))
    # order [Rx, Vx, ax, Ry, Vy, ay]
    F[0, 0] = 1.0; F[0, 1] = s / w; F[0, 4] = -(1 - c) / w
    F[1, 1] = c; F[1, 4] = -s
    F[3, 3] = 1.0; F[3, 1] = (1 - c) / w; F[3, 4] = s / w
    F[4, 1] = s; F[4, 4] = c
    # centripetal acceleration of the new velocity: ax = -w Vy', ay = w Vx'
    F[2] = -w * F[4]
    F[5] = w * F[1]
    return F


def radar_h(x):
    """[range, range rate, bearing] of states ``x`` (..., 6), radar at the origin."""
    px, vx, py, vy = x[..., 0], x[..., 1], x[..., 3], x[..., 4]
    out = np.empty(x.shape[:-1] + (3,), dtype=x.dtype if x.dtype.kind == "f" else np.float64)
    r = np.hypot(px, py, out=out[..., 0])
    rdot = np.multiply(px, vx, out=out[..., 1])          # (px vx + py vy) / r, written in place
    rdot += py * vy
    rdot /= r
    np.arctan2(py, px, out=out[..., 2])
    return out


def radar_jacobian(x):
    """d h / d x (..., 3, 6) of :func:`radar_h`."""
    px, vx, py, vy = x[..., 0], x[..., 1], x[..., 3], x[..., 4]
    r2 = px * px + py * py
    r = np.sqrt(r2)
    rdot = (px * vx + py * vy) / r
    H = np.zeros(x.shape[:-1] + (3, 6))
    H[..., 0, 0] = px / r
    H[..., 0, 3] = py / r
    H[..., 1, 0] = (vx - rdot * px / r) / r
    H[..., 1, 1] = px / r
    H[..., 1, 3] = (vy - rdot * py / r) / r
    H[..., 1, 4] = py / r
    H[..., 2, 0] = -py / r2
    H[..., 2, 3] = px / r2
    return H


class RadarTrackingModel(StateSpaceModel):
    """Linear 6-D motion model x_k = F x_{k-1} + w, w ~ N(0, Q) (Q may be singular), radar measurement.

    Parameters
    ----------
    F : ndarray
        ``(6, 6)`` transition matrix.
    Q : ndarray
        ``(6, 6)`` process noise (positive semi-definite).
    sigma_r, sigma_rdot, sigma_theta : float
        Measurement noise standard deviations of range (m), range rate (m/s) and bearing (rad);
        R = diag(sigma_r^2, sigma_rdot^2, sigma_theta^2).
    x0 : ndarray
        True initial state.
    m0, P0 : ndarray
        The filters' initial distribution.
    name : str
        A short name (CV, CT, CA, ...).
    """

    def __init__(self, F, Q, sigma_r, sigma_rdot, sigma_theta, x0, m0=None, P0=None, name="tracking"):
        self.F = np.asarray(F, float)
        if self.F.shape != (6, 6) or not np.all(np.isfinite(self.F)):
            raise ValueError(f"F must be a finite 6x6 matrix, got shape {self.F.shape}")
        for v, nm in ((sigma_r, "sigma_r"), (sigma_rdot, "sigma_rdot"), (sigma_theta, "sigma_theta")):
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"{nm} must be a positive number, got {v!r}")
        R = np.diag([sigma_r ** 2, sigma_rdot ** 2, sigma_theta ** 2])
        m0 = x0 if m0 is None else m0
        P0 = np.eye(6) if P0 is None else P0
        super().__init__(6, 3, Q, R, x0, m0, P0)
        self.name = str(name)
        self.sigmas = (float(sigma_r), float(sigma_rdot), float(sigma_theta))

    #: optional low-rank factor B (6, q) with Q = B B^T; set by the model builders below
    noise_factor = None

    def f(self, x, k):
        # einsum: row i of a batch must not depend on the batch size (a 2-D matmul goes to BLAS,
        # whose blocking, and so its last bits, change with the number of rows)
        return np.einsum("ij,...j->...i", self.F, x)

    def sample_transition(self, x, k, rng):
        """x_k = F x + w. With a low-rank factor B (Q = B B^T) only rank(Q) normals are drawn per state
        (``rng.standard_normal((*x.shape[:-1], q))``, runs axis first), else the generic draw."""
        if self.noise_factor is None:
            return super().sample_transition(x, k, rng)
        B = self.noise_factor
        z = rng.standard_normal(x.shape[:-1] + (B.shape[1],))
        # stacked matmuls on the batch as it is: reshaping to one tall 2-D product sends it to a
        # threaded BLAS call that is many times slower on a loaded machine; a 2-D batch (one
        # state per run) goes through batch_matmul, whose rows do not depend on the batch size
        out = batch_matmul(z, B)
        out += batch_matmul(x, self.F)
        return out

    def jacobian_f(self, x, k):
        return np.broadcast_to(self.F, x.shape[:-1] + (6, 6))

    def h(self, x):
        return radar_h(x)

    def jacobian_h(self, x):
        return radar_jacobian(x)

    def residual_y(self, y, y_pred):
        """y - y_pred with the bearing difference wrapped to (-pi, pi]."""
        d = y - y_pred
        wrap_angle(d[..., 2], out=d[..., 2])
        return d


def _model(F, G, q, meas, x0, m0, P0, name):
    m = RadarTrackingModel(F, process_noise_Q(G, q), *meas, x0=x0, m0=m0, P0=P0, name=name)
    m.noise_factor = np.sqrt(q) * np.kron(np.eye(2), np.asarray(G, float)[:, None])   # Q = B B^T, B (6, 2)
    return m


def cv_model(T, q, meas, x0, m0=None, P0=None):
    """CV mode model (``meas`` = (sigma_r, sigma_rdot, sigma_theta))."""
    F, G = cv_axis(T)
    return _model(block_diag_axes(F), G, q, meas, x0, m0, P0, "CV")


def ca_model(T, q, meas, x0, m0=None, P0=None):
    """CA mode model."""
    F, G = ca_axis(T)
    return _model(block_diag_axes(F), G, q, meas, x0, m0, P0, "CA")


def ct_model(T, w, q, meas, x0, m0=None, P0=None):
    """Per-axis CT mode model with turn rate ``w`` (rad/s)."""
    F, G = ct_axis(T, w)
    return _model(block_diag_axes(F), G, q, meas, x0, m0, P0, "CT")


def coupled_ct_model(T, w, q, meas, x0, m0=None, P0=None):
    """Exact coordinated turn (truth), DWNA noise on position and velocity (G = [T^2/2, T, 0])."""
    _, G = cv_axis(T)
    return _model(coupled_ct_matrix(T, w), G, q, meas, x0, m0, P0,
                  "CT left" if w > 0 else "CT right")
