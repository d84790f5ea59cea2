"""A covariance that varies continuously with AGB, built on Men et al. (2021), Table I, so that sweeps
over AGB are possible.

* sigma_hv follows the power law of eq. (15): ``sigma_hv(B) = sigma_ref (B / B_ref)^(1/p)``. The
  exponent p is the biome's (2.2 boreal, 1.9 tropical, Section III-D) unless given; sigma_ref at B_ref is
  fitted to the biome's Table I points by least squares in log space with p fixed.
* The co-polarised terms are carried as ratios to sigma_hv (sigma_hh/sigma_hv, sigma_vv/sigma_hv), with
  the HH-VV coherence magnitude ``|rho| = R / sqrt(sigma_hh sigma_vv)`` and phase theta; these four are
  interpolated linearly in ln(AGB) between the Table I points and held constant beyond them. Interpolating
  |rho| (in [0, 1]) rather than R keeps the covariance positive semi-definite.
* Reciprocity (S_hv = S_vh) and reflection symmetry (<S_hh S_hv*> = <S_hv S_vv*> = 0) are assumed, as in
  the paper.

Tropical forest has only two Table I points, both dense forest at nearly the same AGB (338 and 341 t/ha)
and very different sigma_hv: the tropical model therefore uses their mean ratios and anchors sigma_hv at
the geometric mean of the two at their mean AGB. It is a rough guide away from ~340 t/ha; the
``table1_forest`` scene gives the measured covariances exactly.
"""

from __future__ import annotations

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.scene.biome_power_laws import BIOME_EXPONENTS
from e2esim.scene.covariance import ScatteringCovariance
from e2esim.scene.table1 import TABLE1_FORESTS


def _biome_points(biome: str) -> np.ndarray:
    rows = [v[1:] for v in TABLE1_FORESTS.values() if v[0] == biome]
    if not rows:
        raise PhysicsInputError(f"no Table I forests for biome {biome!r}; expected one of {sorted(BIOME_EXPONENTS)}")
    return np.array(rows, dtype=float)  # columns: agb, hh, hv, vv, R, theta_deg


def forest_covariance(biome: str, agb_t_ha: float, exponent: float | None = None) -> ScatteringCovariance:
    """Covariance of a ``biome`` forest at ``agb_t_ha`` (t/ha) under the model of this module."""
    if not agb_t_ha > 0:
        raise PhysicsInputError(f"AGB must be > 0 t/ha, got {agb_t_ha}")
    pts = _biome_points(biome)
    p = BIOME_EXPONENTS[biome] if exponent is None else float(exponent)
    agb, hh, hv, vv, r, theta = pts.T
    log_agb = np.log(agb)
    # sigma_ref at the (geometric) mean AGB, least squares in log space with p fixed.
    log_ref_agb = log_agb.mean()
    log_sigma_ref = np.mean(np.log(hv) - (log_agb - log_ref_agb) / p)
    sigma_hv = float(np.exp(log_sigma_ref + (np.log(agb_t_ha) - log_ref_agb) / p))
    order = np.argsort(log_agb)
    ratios = {
        "hh": hh / hv,
        "vv": vv / hv,
        "coherence": r / np.sqrt(hh * vv),
        "theta": np.radians(theta),
    }
    x = np.log(agb_t_ha)
    if np.ptp(log_agb) < np.log(1.05):  # points too close to interpolate: use their mean
        interp = {k: float(np.mean(v)) for k, v in ratios.items()}
    else:
        interp = {k: float(np.interp(x, log_agb[order], v[order])) for k, v in ratios.items()}
    sigma_hh, sigma_vv = interp["hh"] * sigma_hv, interp["vv"] * sigma_hv
    return ScatteringCovariance.from_powers(
        sigma_hh,
        sigma_hv,
        sigma_vv,
        interp["coherence"] * np.sqrt(sigma_hh * sigma_vv),
        interp["theta"],
        agb_t_ha=float(agb_t_ha),
        biome=biome,
        label=f"{biome} {agb_t_ha:g} t/ha (AGB model on Men et al. 2021, Table I)",
    )
