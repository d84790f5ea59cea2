"""Random volume over ground (RVoG): the forest's vertical structure seen by a pair of passes.

Papathanassiou & Cloude (2001), IEEE TGRS 39(11) 2352-2363; the forms below agree with the BioPAL volume
decorrelation code (github.com/BioPAL/BioPAL, ``biopal/fh/processing_FH.py``, ``volume_decorrelation_lut``). A
volume of height h_v with a power extinction sigma_e
(per metre of slant path) over a ground. The backscatter of a layer at height z is attenuated on the way
down and up through the canopy above it, ``exp(-p (h_v - z))`` with ``p = 2 sigma_e / cos theta``, so the
volume coherence of an interferogram of vertical wavenumber kappa is

    gamma_vol(kappa) = int_0^h e^{p z} e^{j kappa z} dz / int_0^h e^{p z} dz
                     = p (e^{(p + j kappa) h} - 1) / ((p + j kappa)(e^{p h} - 1))      (ground-cancellation.md, eq. 2)

(limits: (e^{j kappa h} - 1)/(j kappa h) for p -> 0). The ground, at height 0, has coherence 1 after ground
steering. Polarimetrically (Papathanassiou & Cloude 2001, eqs. for T6) the single-pass covariance splits as
C = T_v + T_g, volume plus ground, both reflection symmetric; the ground-to-volume ratio mu_pq = T_g,pq/T_v,pq
of each channel is the *effective* one (ground power already attenuated by the canopy), as in the RVoG model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.scene.covariance import ScatteringCovariance

DB_PER_NEPER = 10.0 / np.log(10.0)  # a power ratio of e is 4.343 dB


def volume_coherence(kappa, height_m: float, extinction_np_m: float, incidence_rad: float) -> np.ndarray:
    """gamma_vol(kappa), eq. (2), for vertical wavenumbers ``kappa`` (rad/m, any shape); complex.

    extinction_np_m : power extinction sigma_e (neper per metre of slant path; 1 Np = 4.343 dB).
    """
    kappa = np.asarray(kappa, float)
    p = 2.0 * extinction_np_m / np.cos(incidence_rad)
    h = height_m
    if p * h < 1e-9:  # no extinction: uniform profile
        x = kappa * h
        small = np.abs(x) < 1e-8
        with np.errstate(invalid="ignore", divide="ignore"):
            g = np.where(small, 1.0 + 0.5j * x, np.expm1(1j * x) / (1j * np.where(small, 1.0, x)))
        return g
    a = p + 1j * kappa
    # p / (e^{ph} - 1) * (e^{a h} - 1) / a, written with expm1 for accuracy at small kappa h
    return p / np.expm1(p * h) * np.expm1(a * h) / a


@dataclass(frozen=True)
class ForestStructure:
    """The vertical structure of a forest for the RVoG model.

    height_m : volume height h_v (m). extinction_db_m : power extinction (dB per metre of slant path).
    ground_to_volume_db : effective ground-to-volume ratio mu of (hh, hv, vv) in dB.
    volume_hhvv_coherence : <S_hh S_vv*> / sqrt(sigma_hh sigma_vv) of the volume (real; 1/3 for a cloud of
        randomly oriented thin dipoles, Freeman & Durden 1998).
    label : what the numbers are (and where they come from).
    """

    height_m: float
    extinction_db_m: float
    ground_to_volume_db: tuple
    volume_hhvv_coherence: float = 1.0 / 3.0
    label: str = "forest"

    def __post_init__(self):
        mu = tuple(float(x) for x in self.ground_to_volume_db)
        if len(mu) != 3 or not all(np.isfinite(mu)):
            raise PhysicsInputError(f"ground_to_volume_db needs three finite values (hh, hv, vv), got {mu}")
        if not (self.height_m > 0 and self.extinction_db_m >= 0 and 0 <= self.volume_hhvv_coherence <= 1):
            raise PhysicsInputError(
                "forest height must be > 0, extinction >= 0 and the volume HH-VV coherence in [0, 1], got "
                f"{self.height_m}, {self.extinction_db_m}, {self.volume_hhvv_coherence}")
        object.__setattr__(self, "ground_to_volume_db", mu)

    @property
    def extinction_np_m(self) -> float:
        return self.extinction_db_m / DB_PER_NEPER

    def coherence(self, kappa, incidence_rad: float) -> np.ndarray:
        return volume_coherence(kappa, self.height_m, self.extinction_np_m, incidence_rad)


def split_covariance(cov: ScatteringCovariance, forest: ForestStructure) -> tuple[np.ndarray, np.ndarray]:
    """(T_v, T_g): volume and ground 3x3 covariances with T_v + T_g = C, the given single-pass covariance.

    The powers split by the ground-to-volume ratios, T_g,pp = C_pp mu_p / (1 + mu_p); the volume's HH-VV
    correlation is ``volume_hhvv_coherence`` sqrt(T_v,hh T_v,vv), the ground's the rest. Raises
    PhysicsInputError when the ground covariance left is not positive semi-definite.
    """
    c = np.asarray(cov.matrix)
    if not cov.is_reflection_symmetric():
        raise PhysicsInputError("the RVoG split needs a reflection-symmetric covariance (no HH-HV or HV-VV "
                                "correlation)")
    mu = 10.0 ** (np.asarray(forest.ground_to_volume_db) / 10.0)
    power = np.real(np.diag(c))
    ground_power = power * mu / (1 + mu)
    vol_power = power - ground_power
    tv = np.diag(vol_power).astype(complex)
    tv[0, 2] = tv[2, 0] = forest.volume_hhvv_coherence * np.sqrt(vol_power[0] * vol_power[2])
    tg = c - tv
    w = np.linalg.eigvalsh(tg)
    if w[0] < -1e-12 * np.max(np.abs(w)):
        rho = abs(tg[0, 2]) / np.sqrt(tg[0, 0].real * tg[2, 2].real)
        raise PhysicsInputError(
            f"the ground part of {cov.label} is not a covariance: its HH-VV coherence would be {rho:.3f} > 1 with "
            f"ground-to-volume ratios {forest.ground_to_volume_db} dB and volume HH-VV coherence "
            f"{forest.volume_hhvv_coherence:.3g}; raise the HH and VV ground-to-volume ratios or the volume coherence")
    return tv, tg
