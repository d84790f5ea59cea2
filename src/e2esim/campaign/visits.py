"""What each visit of a calibration site measures, and how well (issue 25, item 3).

The error variance of one visit's estimate of each parameter, from the site's SNR or SCR, its number of looks, its
stability and the Faraday-rotation correction, at the visit's incidence angle:

* gain |A|^2 (dB^2) at the visit's elevation angle (``antenna``). A point target (transponder, corner reflector,
  point scatterers): the relative SD of its peak power in clutter and noise, sqrt((2/c + 1/c^2) / N) with
  1/c = 1/SCR + 1/SNR (``calibration.radiometric.point_target_power_sd``; Ahmed et al. 2014, eq. 33 form). A
  distributed target of N independent looks with the noise power subtracted: (1 + 1/SNR) / sqrt(N) (the SD of an
  N-look mean intensity over the signal power). Both plus the site's stability in quadrature, converted by
  10/ln 10 dB per unit relative power; scintillation adds the point target's peak-power loss (``visit_ionosphere``).
* crosstalk delta (complex, E|delta_hat - delta|^2): a point calibrator's cross-polarised response over its
  co-polarised one, 1/(c N); a distributed target (Quegan 1994 on a reflection-symmetric scene), (1 + 1/SNR)^2 / N.
  Both plus the residual Faraday rotation's variance E[dOmega^2] (``visit_ionosphere``: the climatology's Omega at
  the visit corrected by its estimate): to first order a rotation error dOmega is the antisymmetric
  crosstalk dOmega [[0, 1], [-1, 0]] (Quegan et al. 2018, eq. 11), which no crosstalk estimate can tell apart.
* channel imbalance f (complex, relative, E|f_hat/f - 1|^2): the ratio of two co-polarised responses, 2/(c N) for a
  point calibrator, 2 (1 + 1/SNR)^2 / N for a distributed target with known HH/VV ratio, plus the stability.

A site that does not calibrate a parameter gives it an infinite variance (no information). The incidence
dependence of a distributed target's SNR is ``incidence_slope_db_per_deg`` about 29 deg (the Aquarius incidence
of Quegan et al. 2018, Section 4).
"""

from __future__ import annotations

import numpy as np

from e2esim.calibration.radiometric import DB_PER_NEPER_POWER
from e2esim.campaign.sites import CalibrationSite

REFERENCE_INCIDENCE_DEG = 29.0
POINT_TYPES = ("transponder", "corner_reflector", "point_scatterers")


def visit_snr(site: CalibrationSite, incidence) -> np.ndarray:
    """The site's SNR at the visits' incidence (its ``incidence_slope_db_per_deg`` about 29 deg), linear."""
    snr_db = site.snr_db + site.incidence_slope_db_per_deg * (np.degrees(incidence) - REFERENCE_INCIDENCE_DEG)
    return 10 ** (np.asarray(snr_db, float) / 10)


def visit_variances(site: CalibrationSite, incidence, faraday_variance, scintillation_gain_db2=0.0) -> dict:
    """{parameter: variance of one visit's estimate, shape of ``incidence``} (gain in dB^2; crosstalk and
    imbalance linear). faraday_variance : the residual Faraday rotation's variance at each visit (rad^2);
    scintillation_gain_db2 : the scintillation's peak-power term of a point target (dB^2; ``visit_ionosphere``)."""
    inc = np.asarray(incidence, float)
    snr = visit_snr(site, inc)
    n = site.looks
    if site.type in POINT_TYPES:
        c = 1 / (1 / site.scr + 1 / snr)
        rel_power = (2 / c + 1 / c**2) / n
        xt = 1 / (c * n)
        imb = 2 / (c * n)
    else:
        rel_power = (1 + 1 / snr) ** 2 / n
        xt = (1 + 1 / snr) ** 2 / n
        imb = 2 * (1 + 1 / snr) ** 2 / n
    out = {
        "gain": DB_PER_NEPER_POWER**2 * (rel_power + site.stability**2) + scintillation_gain_db2,
        "crosstalk": xt + faraday_variance,
        "imbalance": imb + site.stability**2,
    }
    return {k: (v if k in site.calibrates else np.full(inc.shape, np.inf)) for k, v in out.items()}
