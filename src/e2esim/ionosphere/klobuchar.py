"""The Klobuchar broadcast ionosphere model: the documented simple fallback when the IRI is not wanted.

Klobuchar (1987), IEEE Trans. Aerosp. Electron. Syst. 23(3), 325-331; IS-GPS-200, Section 20.3.3.5.2.5.
Vertical group delay at the ionospheric pierce point (geographic latitude phi_i, longitude lambda_i, both
in semicircles), local time t (s):

    phi_m = phi_i + 0.064 cos(lambda_i - 1.617)         (geomagnetic latitude, semicircles)
    A = max(0, sum_n alpha_n phi_m^n),  P = max(72000, sum_n beta_n phi_m^n)
    x = 2 pi (t - 50400) / P
    T_v = 5e-9 + A (1 - x^2/2 + x^4/24)  for |x| < 1.57, else 5e-9   (s, at GPS L1)

and vertical TEC = c T_v f_L1^2 / 40.308 (``RANGE_DELAY_CONSTANT``). Night-time TEC is the constant
9.2 TECU (5 ns); the day-time bump is a half cosine peaking at 14:00 local time. The eight coefficients
are broadcast daily by GPS; the defaults are RTKLIB's ``ion_default`` (broadcast of 2004-01-01, moderate
solar activity). The model is meant to remove about half of the GPS range error (Klobuchar 1987); it has no
F10.7 input, no profile and no dawn/dusk structure beyond the cosine, so it is a rough fallback only.
"""

from __future__ import annotations

import numpy as np

from e2esim.ionosphere.constants import RANGE_DELAY_CONSTANT, SPEED_OF_LIGHT

GPS_L1_HZ = 1575.42e6
KLOBUCHAR_ALPHA_DEFAULT = (0.1118e-07, -0.7451e-08, -0.5961e-07, 0.1192e-06)
"""alpha_0..3 (s/semicircle^n), RTKLIB ion_default (GPS broadcast of 2004-01-01)."""
KLOBUCHAR_BETA_DEFAULT = (0.1167e06, -0.2294e06, -0.1311e06, 0.1049e07)
"""beta_0..3 (s/semicircle^n), RTKLIB ion_default (GPS broadcast of 2004-01-01)."""


def klobuchar_vertical_delay(lat, lon, ut_h, alpha=KLOBUCHAR_ALPHA_DEFAULT, beta=KLOBUCHAR_BETA_DEFAULT):
    """Vertical ionospheric group delay at GPS L1 (s) at pierce points (lat, lon in rad) and UT (h)."""
    phi_i = np.asarray(lat, float) / np.pi
    lam_i = np.asarray(lon, float) / np.pi
    phi_m = phi_i + 0.064 * np.cos((lam_i - 1.617) * np.pi)
    t = np.mod(43200.0 * lam_i + np.asarray(ut_h, float) * 3600.0, 86400.0)
    amp = np.maximum(sum(a * phi_m**n for n, a in enumerate(alpha)), 0.0)
    per = np.maximum(sum(b * phi_m**n for n, b in enumerate(beta)), 72000.0)
    x = 2 * np.pi * (t - 50400.0) / per
    day = np.abs(x) < 1.57
    return 5e-9 + np.where(day, amp * (1 - x**2 / 2 + x**4 / 24), 0.0)


def klobuchar_vtec(lat, lon, ut_h, alpha=KLOBUCHAR_ALPHA_DEFAULT, beta=KLOBUCHAR_BETA_DEFAULT):
    """Vertical TEC (electrons/m^2) of the Klobuchar model at pierce points (rad) and UT (h)."""
    delay_m = SPEED_OF_LIGHT * klobuchar_vertical_delay(lat, lon, ut_h, alpha, beta)
    return delay_m * GPS_L1_HZ**2 / RANGE_DELAY_CONSTANT
