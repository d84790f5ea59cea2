"""Forest covariances of Men et al. (2021), Table I (P-band, backscattering coefficients in m^2/m^2).

Boreal values from Quegan & Lomas (2015) as embodied in the BIOMASS end-to-end simulator; tropical
values from TropiSAR (338 t/ha) and AfriSAR (341 t/ha). ``R = |<S_hh S_vv*>|`` and ``theta`` its phase.
"""

from __future__ import annotations

TABLE1_FORESTS = {
    # name: (biome, AGB t/ha, sigma_hh, sigma_hv, sigma_vv, R, theta_deg)
    "boreal_50": ("boreal", 50.0, 0.213, 0.0404, 0.250, 0.086, -54.6),
    "boreal_200": ("boreal", 200.0, 0.649, 0.0726, 0.274, 0.150, -96.8),
    "boreal_350": ("boreal", 350.0, 1.018, 0.0919, 0.281, 0.172, -139.1),
    "tropical_338": ("tropical", 338.0, 0.127, 0.0482, 0.145, 0.022, -21.0),
    "tropical_341": ("tropical", 341.0, 0.182, 0.086, 0.186, 0.042, -15.9),
}
"""Men et al. (2021), Table I: biome, AGB (t/ha), sigma_hh, sigma_hv, sigma_vv, R (m^2/m^2), theta (deg)."""
