"""Point calibrators and their measured responses in clutter.

Scattering matrices in the project's convention ``[[S_hh, S_vh], [S_hv, S_vv]]`` (rows receive, columns
transmit; docs/conventions.md), normalised to a peak element of amplitude 1 (RCS scale set separately):

* trihedral corner reflector: ``I`` (odd bounce);
* dihedral with its fold at angle ``phi`` to the horizontal: ``[[cos 2phi, sin 2phi], [sin 2phi, -cos 2phi]]``
  (even bounce; 0, 22.5 and 45 deg are the usual ones);
* polarimetric active radar calibrator (PARC) or transponder with one non-zero element, e.g.
  ``"hv"``: only S_hv (transmit h, receive v). Such devices need not be reciprocal (Quegan et al. 2018,
  Section 5.1: "4 independent scatterers in which only one of the elements of the true scattering
  matrix is non-zero").

A calibrator sits in a resolution cell with clutter (a distributed target, covariance C) and noise. The
signal-to-clutter ratio (SCR) is the calibrator's peak power ``|S_peak|^2`` over the mean co-polarised
clutter power in the cell, ``(C_hh + C_vv) / 2``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.polarimetry.simulate import SystemState, matrix_root, reciprocal_covariance4
from e2esim.polarimetry.system_model import measured_matrix, to_matrix, to_vector

TRANSPONDER_CHANNELS = ("hh", "hv", "vh", "vv")


def trihedral() -> np.ndarray:
    """Trihedral corner reflector, ``[[1, 0], [0, 1]]``."""
    return np.eye(2, dtype=complex)


def dihedral(angle_rad: float) -> np.ndarray:
    """Dihedral rotated by ``angle_rad`` about the line of sight: ``[[c2, s2], [s2, -c2]]``."""
    c, s = np.cos(2 * angle_rad), np.sin(2 * angle_rad)
    return np.array([[c, s], [s, -c]], dtype=complex)


def transponder(channel: str) -> np.ndarray:
    """PARC / transponder with one non-zero element, ``channel`` in (hh, hv, vh, vv)."""
    if channel not in TRANSPONDER_CHANNELS:
        raise PhysicsInputError(f"transponder channel {channel!r} is not one of {TRANSPONDER_CHANNELS}")
    v = np.zeros(4, dtype=complex)
    v[TRANSPONDER_CHANNELS.index(channel)] = 1.0
    return to_matrix(v)


TARGET_NAMES = (
    "trihedral", "dihedral_0", "dihedral_22.5", "dihedral_45",
    "transponder_hh", "transponder_hv", "transponder_vh", "transponder_vv",
)


def target_matrix(name: str) -> np.ndarray:
    """Scattering matrix of a named calibrator (``TARGET_NAMES``)."""
    if name == "trihedral":
        return trihedral()
    if name.startswith("dihedral_"):
        try:
            angle = float(name.split("_", 1)[1])
        except ValueError:
            angle = None
        if angle is not None:
            return dihedral(np.radians(angle))
    if name.startswith("transponder_"):
        return transponder(name.split("_", 1)[1])
    raise PhysicsInputError(f"unknown calibrator {name!r}; expected one of {', '.join(TARGET_NAMES)}")


@dataclass(frozen=True)
class Calibrators:
    """A set of point calibrators: their scattering matrices and the conditions they are seen in.

    matrices : (K, 2, 2) true scattering matrices (peak element amplitude 1). names : K labels.
    scr : signal-to-clutter ratio of each (linear, peak power over mean co-pol clutter power), shape (K,).
    clutter : 3x3 clutter covariance shape (hh, hv, vv); scaled per calibrator to its SCR.
    noise_to_signal : thermal noise power per channel over the calibrator's peak power (linear).
    """

    matrices: np.ndarray
    names: tuple
    scr: np.ndarray
    clutter: np.ndarray
    noise_to_signal: float = 0.0

    @classmethod
    def named(cls, names, scr_db, clutter: np.ndarray, noise_to_signal_db: float | None = None) -> Calibrators:
        """``from_ratios`` with the signal-to-clutter and noise-to-signal ratios in dB."""
        nts = 0.0 if noise_to_signal_db is None else 10 ** (noise_to_signal_db / 10)
        return cls.from_ratios(names, 10 ** (np.asarray(scr_db, dtype=float) / 10), clutter, nts)

    @classmethod
    def from_ratios(cls, names, scr, clutter: np.ndarray, noise_to_signal: float = 0.0) -> Calibrators:
        """Calibrators ``names`` (``TARGET_NAMES``) with signal-to-clutter ratio ``scr`` (linear, one or per
        calibrator), clutter shape (3x3, hh/hv/vv) and peak noise-to-signal ratio (linear)."""
        names = tuple(names)
        if not names:
            raise PhysicsInputError("give at least one calibrator")
        scr = np.broadcast_to(np.asarray(scr, dtype=float), (len(names),))
        nts = float(noise_to_signal)
        clutter = np.asarray(clutter, dtype=complex)
        if clutter.shape != (3, 3):
            raise PhysicsInputError(f"clutter covariance must be 3x3 (hh, hv, vv), got shape {clutter.shape}")
        return cls(np.stack([target_matrix(n) for n in names]), names, scr, clutter, nts)

    @property
    def count(self) -> int:
        return len(self.names)

    def clutter_scales(self) -> np.ndarray:
        """(K,) factor from the clutter shape to each cell's clutter: ``1 / (SCR (C_hh + C_vv) / 2)``."""
        co = 0.5 * float(np.real(self.clutter[0, 0] + self.clutter[2, 2]))
        return 1.0 / (co * self.scr)

    def clutter_covariances(self) -> np.ndarray:
        """(K, 4, 4) covariance of the clutter scattering vector (hh, hv, vh, vv) in each cell."""
        return reciprocal_covariance4(self.clutter)[None] * self.clutter_scales()[:, None, None]


def calibrator_responses(rng: np.random.Generator, calibrators: Calibrators, state: SystemState) -> np.ndarray:
    """Measured responses ``M_k = A R F (S_k + clutter_k) F T + N_k`` of every calibrator.

    state : system realisation(s) with leading shape ``batch`` (gain, crosstalk, imbalance and the
        Faraday rotation at the calibration site). Clutter is drawn independently for each calibrator
        and realisation (CN with the covariance scaled to the SCR); noise CN(0, noise_to_signal) per
        channel. Returns (batch..., K, 2, 2).
    """
    batch = state.shape
    k = calibrators.count
    roots = matrix_root(calibrators.clutter_covariances())  # (K, 4, 4)
    xi = (rng.standard_normal(batch + (k, 4)) + 1j * rng.standard_normal(batch + (k, 4))) / np.sqrt(2)
    clutter = to_matrix(np.einsum("kij,...kj->...ki", roots, xi))  # (batch, K, 2, 2); S_vh = S_hv by construction
    scattering = calibrators.matrices + clutter
    expand = (slice(None),) * len(batch) + (None,)
    signal = measured_matrix(
        scattering,
        np.asarray(state.delta)[expand],
        np.asarray(state.f)[expand],
        np.asarray(state.omega)[expand],
        np.asarray(state.gain)[expand],
    )
    nts = calibrators.noise_to_signal
    noise = np.sqrt(nts / 2) * (rng.standard_normal(signal.shape) + 1j * rng.standard_normal(signal.shape))
    return signal + noise


def response_covariance(calibrators: Calibrators, state: SystemState) -> np.ndarray:
    """Covariance of the measured vector vec(M_k) about its mean, (batch..., K, 4, 4): clutter through the
    system, plus noise. Used to weight the least-squares fit and to predict its uncertainty."""
    return operator_covariance(calibrators, state.operator())


def operator_covariance(calibrators: Calibrators, operator: np.ndarray, scales: np.ndarray | None = None) -> np.ndarray:
    """``response_covariance`` for the system's 4x4 operator (batch..., 4, 4), ``A (T^T kron R)(F^T kron F)``.

    scales : the calibrators' ``clutter_scales`` (default); a single one when they are all equal gives the one
    covariance every cell shares, (batch..., 1, 4, 4).
    """
    # every calibrator's clutter has the same shape, scaled to its SCR (clutter_covariances): map it once
    mapped = operator @ reciprocal_covariance4(calibrators.clutter) @ np.swapaxes(operator.conj(), -1, -2)
    scales = calibrators.clutter_scales() if scales is None else scales
    cov = mapped[..., None, :, :] * scales[:, None, None]
    return cov + calibrators.noise_to_signal * np.eye(4)


def mean_response(calibrators: Calibrators, state: SystemState) -> np.ndarray:
    """Noise-free, clutter-free vec(M_k) = K vec(S_k), shape (batch..., K, 4)."""
    kop = state.operator()
    return np.einsum("...ij,kj->...ki", kop, to_vector(calibrators.matrices))
