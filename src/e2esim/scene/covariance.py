"""Scattering covariance of a distributed target and how to draw scenes from it.

The covariance is 3x3 in the reciprocal basis ``(S_hh, S_hv, S_vv)`` (``S_vh = S_hv`` for natural
targets, Men et al. 2021, Section II), in backscattering-coefficient units (m^2/m^2), so that its
diagonal is ``(sigma_hh, sigma_hv, sigma_vv)`` and ``C[0, 2] = <S_hh S_vv*> = R exp(j theta)``
(Table I). Reflection symmetry means ``<S_hh S_hv*> = <S_hv S_vv*> = 0``; the analytic error formulas
of Men et al. (2021) assume it, the Monte Carlo does not.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError

_HERMITIAN_RTOL = 1e-9  # relative tolerance for Hermitian symmetry and PSD checks
_REFLECTION_SYMMETRY_RTOL = 1e-6  # |C_hh,hv| and |C_hv,vv| below this fraction of sqrt(C_ii C_jj)


@dataclass(frozen=True, eq=False)
class ScatteringCovariance:
    """Covariance ``C(i, j) = <S_i S_j*>`` of a distributed target, basis (hh, hv, vv), m^2/m^2.

    matrix : 3x3 complex Hermitian positive semi-definite.
    agb_t_ha : above-ground biomass it represents (t/ha), or None.
    biome : "boreal", "tropical" or another label, or None.
    label : human-readable name (e.g. "boreal 200 t/ha (Men et al. 2021, Table I)").
    """

    matrix: np.ndarray
    agb_t_ha: float | None = None
    biome: str | None = None
    label: str = "scene"

    def __post_init__(self):
        c = np.asarray(self.matrix, dtype=complex)
        if c.shape != (3, 3) or not np.all(np.isfinite(c)):
            raise PhysicsInputError(f"scattering covariance must be a finite 3x3 matrix, got shape {c.shape}")
        scale = max(float(np.max(np.abs(c))), np.finfo(float).tiny)
        if np.max(np.abs(c - c.conj().T)) > _HERMITIAN_RTOL * scale:
            raise PhysicsInputError("scattering covariance is not Hermitian (C != C^H)")
        c = 0.5 * (c + c.conj().T)
        eig = np.linalg.eigvalsh(c)
        if eig[0] < -_HERMITIAN_RTOL * scale:
            raise PhysicsInputError(
                "scattering covariance is not positive semi-definite "
                f"(smallest eigenvalue {eig[0]:.3g}); e.g. |<S_hh S_vv*>| must not exceed "
                "sqrt(sigma_hh sigma_vv)"
            )
        if np.any(np.real(np.diag(c)) <= 0):
            raise PhysicsInputError("backscattering coefficients sigma_hh, sigma_hv, sigma_vv must be > 0")
        c.setflags(write=False)
        object.__setattr__(self, "matrix", c)

    # Table I style description --------------------------------------------------------------
    @classmethod
    def from_powers(cls, sigma_hh, sigma_hv, sigma_vv, hhvv_magnitude, hhvv_phase_rad, **kw):
        """Reflection-symmetric covariance from Men et al. (2021), Table I columns.

        ``<S_hh S_vv*> = R exp(j theta)`` with R = ``hhvv_magnitude`` (m^2/m^2) and theta =
        ``hhvv_phase_rad``.
        """
        hhvv = hhvv_magnitude * np.exp(1j * hhvv_phase_rad)
        m = np.array(
            [[sigma_hh, 0, hhvv], [0, sigma_hv, 0], [np.conj(hhvv), 0, sigma_vv]], dtype=complex
        )
        return cls(m, **kw)

    @property
    def sigma_hh(self) -> float:
        return float(self.matrix[0, 0].real)

    @property
    def sigma_hv(self) -> float:
        return float(self.matrix[1, 1].real)

    @property
    def sigma_vv(self) -> float:
        return float(self.matrix[2, 2].real)

    @property
    def hhvv(self) -> complex:
        """``<S_hh S_vv*> = R exp(j theta)``."""
        return complex(self.matrix[0, 2])

    @property
    def hhvv_magnitude(self) -> float:
        return abs(self.hhvv)

    @property
    def hhvv_phase_rad(self) -> float:
        return float(np.angle(self.hhvv))

    def scalars(self) -> dict:
        """Output scalars (``scene.*``): the three powers and the HH-VV correlation (m^2/m^2, deg), the AGB."""
        return {
            "sigma_hh": self.sigma_hh, "sigma_hv": self.sigma_hv, "sigma_vv": self.sigma_vv,
            "hhvv_magnitude": self.hhvv_magnitude, "hhvv_phase_deg": math.degrees(self.hhvv_phase_rad),
            "agb_t_ha": float("nan") if self.agb_t_ha is None else self.agb_t_ha,
        }

    def is_reflection_symmetric(self, rtol: float = _REFLECTION_SYMMETRY_RTOL) -> bool:
        d = np.sqrt(np.real(np.diag(self.matrix)))
        return bool(
            abs(self.matrix[0, 1]) <= rtol * d[0] * d[1] and abs(self.matrix[1, 2]) <= rtol * d[1] * d[2]
        )

    # Sampling ---------------------------------------------------------------------------------
    def cholesky(self) -> np.ndarray:
        """Lower-triangular L with L L^H = C (semi-definite matrices through an eigen-decomposition)."""
        try:
            return np.linalg.cholesky(self.matrix)
        except np.linalg.LinAlgError:
            w, u = np.linalg.eigh(self.matrix)
            # A valid (non-triangular) square root for a singular C: enough for sampling.
            return u * np.sqrt(np.clip(w, 0, None))

    def sample(self, rng: np.random.Generator, size: int | tuple) -> np.ndarray:
        """Scattering vectors ``(S_hh, S_hv, S_vv)`` ~ CN(0, C), shape ``size + (3,)``.

        Men et al. (2021), Section IV step 1: zero-mean complex Gaussian through the Cholesky factor.
        """
        size = (size,) if np.isscalar(size) else tuple(size)
        xi = (rng.standard_normal(size + (3,)) + 1j * rng.standard_normal(size + (3,))) / np.sqrt(2)
        return xi @ self.cholesky().T

    def sample_covariance(self, rng: np.random.Generator, looks: int, size: int | tuple = ()) -> np.ndarray:
        """Sample covariance of ``looks`` independent scattering vectors, without drawing them.

        ``looks * C_hat`` is complex Wishart CW_3(looks, C). Drawn by the Bartlett decomposition
        ``W = L T T^H L^H`` with T lower triangular, ``|T_ii|^2 ~ Gamma(looks - i)`` (i = 0, 1, 2),
        ``T_ij ~ CN(0, 1)`` below the diagonal. Cost independent of ``looks``.
        Shape ``size + (3, 3)``.
        """
        size = (size,) if np.isscalar(size) else tuple(size)
        if looks < 3:
            # Bartlett needs looks >= dimension; draw the vectors for tiny windows.
            s = self.sample(rng, size + (looks,))
            return np.einsum("...ki,...kj->...ij", s, s.conj()) / looks
        t = np.zeros(size + (3, 3), dtype=complex)
        for i in range(3):
            t[..., i, i] = np.sqrt(rng.gamma(looks - i, 1.0, size))
            for j in range(i):
                t[..., i, j] = (rng.standard_normal(size) + 1j * rng.standard_normal(size)) / np.sqrt(2)
        lt = self.cholesky() @ t
        return lt @ np.swapaxes(lt.conj(), -1, -2) / looks
