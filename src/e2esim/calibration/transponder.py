"""All system errors from polarimetric calibrators by non-linear least squares (Quegan et al. 2018, Sect. 5.1).

Each calibrator k of known scattering matrix S_k gives ``vec(M_k) = A (T^T kron R)(F^T kron F) vec(S_k) +
clutter + noise`` (eq. 11): 8 real numbers per response for the 15 real unknowns delta1..4, f1, f2 (12),
Omega (1) and the complex gain A (2). Four or more independent responses over-determine the system.

Identifiability. The responses fix the receive and transmit matrices ``X = A R F(Omega)`` and
``Y = F(Omega) T`` only up to ``X -> X F(eps)``, ``Y -> F(-eps) Y`` (``A R F(Omega) = A R F(eps) F(Omega - eps)``):
one real direction, along which, to first order, ``(delta1, delta2, delta3, delta4, Omega) ->
(delta1 - eps, delta2 + eps, delta3 + eps, delta4 - eps, Omega - eps)``. This is the ambiguity between
Faraday rotation and crosstalk of Quegan et al. (2018), Section 5.2, and it holds for any set of
calibrators. Omega and the crosstalk are therefore separated only by a gauge condition (``GAUGES``):

* ``"min_crosstalk"``: the member with the least total crosstalk power ``sum |delta_i|^2``; its Omega error is
  ``Re(delta2 + delta3 - delta1 - delta4) / 4`` (SD ``sqrt(V_delta (1 - Re rho) / 8)`` for Men et al. 2021's
  crosstalk statistics, 0.1 deg at the BIOMASS specification);
* ``"reciprocal"``: the member closest to a reciprocal antenna (``T = R^T``: delta3 = delta1, delta4 = delta2,
  f2 = f1), exact for a reciprocal system;
* ``"faraday_prior"``: Omega from an independent estimate (e.g. the chirp slope, or a TEC map) with its SD,
  traded against the crosstalk power.

Whatever the gauge, the corrected data ``X^-1 M Y^-1`` are the same up to a rotation, which a
Faraday-rotation estimate on the corrected scene removes; quantities the sigma_hv error depends on
(``delta1 + delta3``, ``delta2 + delta4``, f1, f2) do not move along the gauge to first order.

Solution: Gauss-Newton on the 14 parameters other than Omega, with Omega held at a coarse start value
(any value fits, by the gauge), then the gauge fixed by a one-dimensional minimisation. The residuals are
whitened by the clutter-plus-noise covariance of each response (recomputed at the current estimate), so
the estimate is maximum likelihood for Gaussian clutter. The model is holomorphic in the 7 complex
parameters, so the real Gauss-Newton step is the complex one, ``(G^H G) dz = G^H r``, and ``(G^H G)^-1``
is the Cramer-Rao covariance of the complex parameters at known Omega. Vectorised over any number of
realisations.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.calibration.targets import Calibrators, operator_covariance
from e2esim.errors import PhysicsInputError
from e2esim.polarimetry.simulate import SystemState
from e2esim.polarimetry.small_matrices import hermitian_inverse_factor
from e2esim.polarimetry.system_model import batched_kron, distortion_rows, faraday_matrix, to_vector

GAUGES = ("min_crosstalk", "reciprocal", "faraday_prior")
_START_ANGLES = np.pi * np.arange(-8, 8) / 16  # coarse Omega grid over one period (F(pi) = -I leaves M unchanged)
_GN_ITERATIONS = 5
_REWEIGHT_AT = (0, 1, 2, 3)  # Gauss-Newton iterations at which the whitening is recomputed
_GAUGE_ITERATIONS = 5
_LOADING = 1e-6  # relative diagonal loading of the response covariance used for whitening


@dataclass(frozen=True)
class TransponderSolution:
    """System errors estimated from calibrator responses, shape (...) per realisation.

    delta : (..., 4) crosstalk. f : (..., 2) channel imbalance. omega : Faraday rotation at the site (rad),
    fixed by the gauge. gain : complex gain A. information : (..., 7, 7) ``G^H G`` of the whitened Jacobian at
    the solution (``covariance`` is its inverse). chi2 : whitened residual sum of squares over the 8K real
    residuals, chi-square with 8K - 14 degrees of freedom for a correct model. gauge : the condition.
    """

    delta: np.ndarray
    f: np.ndarray
    omega: np.ndarray
    gain: np.ndarray
    information: np.ndarray
    chi2: np.ndarray
    gauge: str

    @property
    def covariance(self) -> np.ndarray:
        """(..., 7, 7) complex Cramer-Rao covariance ``E[dz dz^H]`` of z = (delta1..4, f1, f2, A) at known Omega
        (real and imaginary parts each have half the diagonal as variance): inverted when asked for, since the
        calibration pipeline uses only the estimates (a stack of 7x7 inverses is a tenth of a solve)."""
        return np.linalg.inv(self.information)

    def state(self) -> SystemState:
        return SystemState(self.delta, self.f, self.omega, self.gain)

    def receive_matrix(self) -> np.ndarray:
        """Estimated ``A R`` (the inner receive correction is its inverse), (..., 2, 2)."""
        d, f = self.delta, self.f
        one = np.ones_like(f[..., 0])
        r = np.stack([np.stack([one, d[..., 1]], -1), np.stack([d[..., 0], f[..., 0]], -1)], -2)
        return self.gain[..., None, None] * r

    def transmit_matrix(self) -> np.ndarray:
        d, f = self.delta, self.f
        one = np.ones_like(f[..., 0])
        return np.stack([np.stack([one, d[..., 2]], -1), np.stack([d[..., 3], f[..., 1]], -1)], -2)


def _faraday_part(omega, svec) -> np.ndarray:
    """``u_k = (F^T kron F) vec(S_k)``, (..., K, 4): constant while Omega is held."""
    rot = faraday_matrix(omega)
    k0 = batched_kron(np.swapaxes(rot, -1, -2), rot)
    return np.einsum("...ij,kj->...ki", k0, svec)


def _jacobian_and_residual(z, u, y) -> np.ndarray:
    """The derivatives of the model ``vec(M_k) = A D(delta, f) u_k`` in the 7 complex parameters
    z = (delta1..4, f1, f2, A), with the residual ``y - model`` beside them as an eighth column, (..., K, 4, 8):
    ready to be whitened in one product (``_whitened_system``). y : measured vec(M_k), (..., K, 4).

    D = T^T kron R has rows [1, d2, d4, d2 d4], [d1, f1, d1 d4, f1 d4], [d3, d2 d3, f2, f2 d2],
    [d1 d3, f1 d3, f2 d1, f1 f2] (Men et al. 2021, eq. 1): multilinear, so the derivatives are exact.
    """
    d1, d2, d3, d4, f1, f2, a = (z[..., i, None] for i in range(7))
    u0, u1, u2, u3 = (u[..., i] for i in range(4))
    du = np.stack([
        u0 + d2 * u1 + d4 * u2 + d2 * d4 * u3,
        d1 * u0 + f1 * u1 + d1 * d4 * u2 + f1 * d4 * u3,
        d3 * u0 + d2 * d3 * u1 + f2 * u2 + f2 * d2 * u3,
        d1 * d3 * u0 + f1 * d3 * u1 + f2 * d1 * u2 + f1 * f2 * u3,
    ], -1)
    # d vec(M) / d z: the cells (row, parameter) of each non-zero entry; the others are zero (D is multilinear).
    # delta2 and f1 share their factors (both multiply u1 and u3), as do delta4 and f2 (u2 and u3).
    entries = (
        (((1, 0),), u0 + d4 * u2), (((3, 0),), d3 * u0 + f2 * u2),  # delta1
        (((0, 1), (1, 4)), u1 + d4 * u3), (((2, 1), (3, 4)), d3 * u1 + f2 * u3),  # delta2, f1
        (((2, 2),), u0 + d2 * u1), (((3, 2),), d1 * u0 + f1 * u1),  # delta3
        (((0, 3), (2, 5)), u2 + d2 * u3), (((1, 3), (3, 5)), d1 * u2 + f1 * u3),  # delta4, f2
    )
    jac = np.zeros(du.shape + (8,), complex)
    for cells, value in entries:
        scaled = a * value
        for row, col in cells:
            jac[..., row, col] = scaled
    jac[..., 6] = du
    jac[..., 7] = y - a[..., None] * du
    return jac


def _whiten(x, whitener) -> np.ndarray:
    """Apply ``W = L^-1`` (..., K or 1, 4, 4) to (..., K, 4, p) and flatten the K responses: (..., 4K, p)."""
    w = whitener @ x
    return w.reshape(w.shape[:-3] + (-1, w.shape[-1]))


def _whitener(z, faraday_kron, calibrators) -> np.ndarray:
    """``W = L^-1``, L the Cholesky factor of the clutter-plus-noise covariance of each response at the current
    estimate (``W Sigma W^H = I``), (..., K, 4, 4); (..., 1, 4, 4) when every calibrator's cell has the same
    covariance (same SCR: one factor serves all). faraday_kron : ``F^T kron F`` at the Omega held."""
    operator = z[..., 6, None, None] * (distortion_rows(z[..., 0:4], z[..., 4:6]) @ faraday_kron)
    scales = calibrators.clutter_scales()
    cov = operator_covariance(calibrators, operator, scales[:1] if np.all(scales == scales[0]) else scales)
    loading = _LOADING * np.real(np.trace(cov, axis1=-2, axis2=-1))[..., None, None] / 4
    cov = cov + loading * np.eye(4)  # reciprocal clutter without noise is singular in the HV - VH direction
    return hermitian_inverse_factor(cov)


def _whitened_system(y, z, u, whitener) -> tuple:
    """Whitened residuals r (..., 4K) and Jacobian G (..., 4K, 7) at z (one product for both)."""
    w = _whiten(_jacobian_and_residual(z, u, y), whitener)
    return w[..., 7], w[..., :7]


def _gain_ls(y, u) -> np.ndarray:
    """Least-squares complex gain with no crosstalk and unit imbalance: the start value of A."""
    return np.sum(np.conj(u) * y, axis=(-2, -1)) / np.sum(np.abs(u) ** 2, axis=(-2, -1))


def solve_transponder(
    responses: np.ndarray,
    calibrators: Calibrators,
    gauge: str = "min_crosstalk",
    faraday_prior: tuple | None = None,
    crosstalk_variance: float = 1e-3,
) -> TransponderSolution:
    """Estimate (delta, f, Omega, A) from calibrator responses (..., K, 2, 2).

    gauge : one of ``GAUGES``. faraday_prior : (mean_rad, sd_rad) for ``"faraday_prior"`` (sd 0: Omega
    known). crosstalk_variance : prior crosstalk power per term, trading it against the Faraday prior.
    """
    if gauge not in GAUGES:
        raise PhysicsInputError(f"gauge must be one of {GAUGES}, got {gauge!r}")
    if gauge == "faraday_prior" and faraday_prior is None:
        raise PhysicsInputError("gauge 'faraday_prior' needs faraday_prior = (mean_rad, sd_rad)")
    responses = np.asarray(responses, dtype=complex)
    if responses.shape[-3:] != (calibrators.count, 2, 2):
        raise PhysicsInputError(f"responses must have shape (..., {calibrators.count}, 2, 2), got {responses.shape}")
    svec = to_vector(calibrators.matrices)  # (K, 4)
    if np.linalg.matrix_rank(svec) < 3:
        raise PhysicsInputError(
            f"calibrators {', '.join(calibrators.names)} span fewer than 3 independent scattering matrices; "
            "the system errors are not determined (use e.g. trihedral, dihedral_0 and dihedral_45, "
            "or four transponders)"
        )
    batch = responses.shape[:-3]
    y = to_vector(responses)  # (..., K, 4)
    omega0, u = _start_angle(y, svec, batch)
    rot = faraday_matrix(omega0)
    faraday_kron = batched_kron(np.swapaxes(rot, -1, -2), rot)  # the operator's Faraday factor, fixed with Omega
    z = np.zeros(batch + (7,), complex)
    z[..., 4:6] = 1.0
    z[..., 6] = _gain_ls(y, u)
    for i in range(_GN_ITERATIONS):
        if i in _REWEIGHT_AT:  # iteratively re-weighted: the clutter maps through the current estimate
            whitener = _whitener(z, faraday_kron, calibrators)
        r, g = _whitened_system(y, z, u, whitener)
        gh = np.conj(np.swapaxes(g, -1, -2))
        # holomorphic model: the real Gauss-Newton step is the complex one, (G^H G) dz = G^H r
        z = z + np.linalg.solve(gh @ g, gh @ r[..., None])[..., 0]
    r, g = _whitened_system(y, z, u, _whitener(z, faraday_kron, calibrators))
    chi2 = 2 * np.sum(np.abs(r) ** 2, -1)  # whitened: E|w|^2 = 1, i.e. variance 1/2 per real component
    information = np.conj(np.swapaxes(g, -1, -2)) @ g
    delta, f, omega, gain = fix_gauge(z[..., 0:4], z[..., 4:6], omega0, z[..., 6], gauge, faraday_prior,
                                      crosstalk_variance)
    return TransponderSolution(delta, f, omega, gain, information, chi2, gauge)


def _start_angle(y, svec, batch) -> tuple:
    """Coarse Omega start and its ``u`` (``_faraday_part``): the grid angle whose crosstalk-free model fits best
    (any angle is an exact fit with suitable crosstalk, so this only keeps the Gauss-Newton in its linear
    regime). The least-squares gain leaves the residual ``|y|^2 - |u^H y|^2 / |u|^2``, so the best angle is the
    one of largest ``|u^H y|^2 / |u|^2``: one matrix product of the responses with the grid's ``u`` (computed
    once, not per realisation) scores every angle at once."""
    grid = np.stack([_faraday_part(angle, svec) for angle in _START_ANGLES])  # (angles, K, 4)
    flat = grid.reshape(len(grid), -1)
    fit = np.abs(y.reshape(batch + (-1,)) @ np.conj(flat).T) ** 2 / np.sum(np.abs(flat) ** 2, -1)
    index = np.argmax(fit, -1)  # the first of equals, as a scan keeping only strictly better angles
    return _START_ANGLES[index], grid[index]


def gauge_transform(delta, f, omega, gain, eps):
    """The equivalent parameters ``R F(eps)``, ``Omega - eps``, ``F(eps) T`` (renormalised), exact.

    With ``R = [[1, d2], [d1, f1]]``, ``T = [[1, d3], [d4, f2]]`` and ``F(eps) = [[c, s], [-s, c]]``:
    ``R F = [[c - s d2, s + c d2], [c d1 - s f1, s d1 + c f1]]`` and
    ``F T = [[c + s d4, c d3 + s f2], [c d4 - s, c f2 - s d3]]``, each divided by its (0, 0) element.
    """
    c, s = np.cos(eps), np.sin(eps)
    d1, d2, d3, d4 = (delta[..., i] for i in range(4))
    f1, f2 = f[..., 0], f[..., 1]
    gr, gt = c - s * d2, c + s * d4
    delta2 = np.stack([(c * d1 - s * f1) / gr, (s + c * d2) / gr, (c * d3 + s * f2) / gt, (c * d4 - s) / gt], -1)
    f2_new = np.stack([(s * d1 + c * f1) / gr, (c * f2 - s * d3) / gt], -1)
    return delta2, f2_new, np.asarray(omega) - eps, gain * gr * gt


def _gauge_cost(delta, f, omega, gauge, prior, crosstalk_variance):
    if gauge == "min_crosstalk":
        return np.sum(np.abs(delta) ** 2, -1)
    if gauge == "reciprocal":
        return np.abs(delta[..., 2] - delta[..., 0]) ** 2 + np.abs(delta[..., 3] - delta[..., 1]) ** 2 + np.abs(
            f[..., 1] - f[..., 0]) ** 2
    mean, sd = prior
    xt = np.sum(np.abs(delta) ** 2, -1) / (4 * crosstalk_variance)
    return (omega - mean) ** 2 / max(sd, 1e-12) ** 2 + xt


def fix_gauge(delta, f, omega, gain, gauge, prior=None, crosstalk_variance=1e-3):
    """Move along the unobservable direction to the member that satisfies ``gauge`` (Newton in eps)."""
    if gauge == "faraday_prior" and prior[1] == 0:
        return gauge_transform(delta, f, omega, gain, np.asarray(omega) - prior[0])
    eps = np.real(delta[..., 0] - delta[..., 1] - delta[..., 2] + delta[..., 3]) / 4  # first-order min-norm
    h = 1e-5
    for _ in range(_GAUGE_ITERATIONS):
        c0 = _gauge_cost(*_tf(delta, f, omega, gain, eps), gauge, prior, crosstalk_variance)
        cp = _gauge_cost(*_tf(delta, f, omega, gain, eps + h), gauge, prior, crosstalk_variance)
        cm = _gauge_cost(*_tf(delta, f, omega, gain, eps - h), gauge, prior, crosstalk_variance)
        d2 = (cp - 2 * c0 + cm) / h**2
        step = -(cp - cm) / (2 * h) / np.where(d2 > 0, d2, np.inf)
        eps = eps + np.clip(step, -0.2, 0.2)
    return gauge_transform(delta, f, omega, gain, eps)


def _tf(delta, f, omega, gain, eps):
    d, ff, om, _ = gauge_transform(delta, f, omega, gain, eps)
    return d, ff, om
