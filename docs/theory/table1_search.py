"""Search the assumptions behind Quegan et al. (2018), Table 1 (docs/theory/ionosphere.md, section 6).

    python docs/theory/table1_search.py

For every combination of incidence, pierce-point height, latitude convention (target or pierce point),
Earth rotation, dipole strength, confidence factor z, slant or ground range and variance form (eq. 5 as
printed or corrected), the excluded zones are computed from |B.k| on a 0.0005 deg latitude grid and
compared with the eight printed edges; the best sets are printed with their largest deviation (deg).
B.k scales with B0, so one profile per geometry serves every dipole strength. Takes about two minutes.
"""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np

from e2esim.ionosphere.geolocation import GeolocationAssumptions, b_dot_k_profile, delay_error_threshold
from e2esim.verification.published import PUBLISHED  # noqa: F401  (loads the value lists in order)
from e2esim.verification.quegan2018_values import TABLE1

TARGET_LAT = np.arange(-8.0, 12.0, 0.0005)
IGRF_2016_B0 = 2.9958e-5  # |m| of IGRF-14 at 2016 (T)


def zone(lat, bk, threshold):
    inside = np.flatnonzero(np.abs(bk) < threshold)
    return (lat[inside[0]], lat[inside[-1]]) if inside.size else (np.nan, np.nan)


def main(top: int = 25) -> None:
    rows = []
    geometries = itertools.product((23.0, 24.0, 25.0, 26.0, 27.0, 28.375, 29.0, 30.0, 31.0, 33.75),
                                   (0.0, 250e3, 300e3, 350e3, 400e3, 450e3), ("target", "pierce"), (False, True))
    for inc, height, lat_at, rotation in geometries:
        if height == 0 and lat_at == "pierce":
            continue
        base = GeolocationAssumptions(incidence_deg=inc, pierce_height_m=height, latitude_at=lat_at,
                                      earth_rotation=rotation, b0_tesla=1.0)
        lat, bk_unit = b_dot_k_profile(base, TARGET_LAT)
        for b0, z, ground, form in itertools.product(
            (IGRF_2016_B0, 3.0e-5, 3.12e-5),
            (1.0, 1.645, 1.96, 2.0, 2.576, 3.0),
            (False, True),
            ("printed", "asymptotic"),
        ):
            a = replace(base, b0_tesla=b0, confidence_z=z, ground_range=ground, variance_form=form)
            err = 0.0
            for (snr, looks), edges in TABLE1.items():
                computed = zone(lat, bk_unit * b0, delay_error_threshold(snr, looks, a))
                err = max(err, *(abs(c - e) for c, e in zip(computed, edges)))
            rows.append((err, inc, height / 1e3, lat_at, rotation, b0, z, "ground" if ground else "slant", form))
    rows.sort(key=lambda r: r[0])
    print("max |deviation| (deg), incidence, height (km), latitude of, Earth rotation, B0 (T), z, range, eq. 5")
    for r in rows[:top]:
        print(
            f"{r[0]:.3f}  {r[1]:6.3f}  {r[2]:5.0f}  {r[3]:6s}  {r[4]!s:5s}  {r[5]:.4g}  {r[6]:5.3f}  {r[7]:6s}  {r[8]}"
        )


if __name__ == "__main__":
    main()
