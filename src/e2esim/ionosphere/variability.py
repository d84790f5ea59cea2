"""Day-to-day variability of the ionosphere about the IRI monthly median.

The IRI gives monthly medians (Bilitza et al. 2022, Rev. Geophys. 60); the TEC of a given day differs from
the median by a factor X. e2esim models X as log-normal with median 1 (so the IRI stays the median) and a
coefficient of variation ``cv``:

    ln X ~ N(0, s^2),   s^2 = ln(1 + cv^2).

Default cv = 0.25: the relative standard deviation of the F2-layer peak density NmF2 (to which TEC is
nearly proportional) is about 20 % by day and 33 % by night over 34 ionosonde stations (Rishbeth &
Mendillo 2001, J. Atmos. Sol.-Terr. Phys. 63, 1661-1680); the BIOMASS passes are at dawn and dusk,
between the two. Moscow ionosonde data 1957-2017 give coefficients of variation of NmF2 of 12-43 %
depending on hour and month (Pavlov & Pavlova 2019, Geomagn. Aeron. 59, 593-605), so the parameter
should be varied in sensitivity studies. Geomagnetic storms are outside this model.

The distribution is represented by ``n`` equiprobable quantile nodes of ln X, scaled so that their
second moment is exactly s^2 (the mean of X then matches exp(s^2/2) to O(1/n^2)).
"""

from __future__ import annotations

import numpy as np

from e2esim.errors import PhysicsInputError

DEFAULT_TEC_VARIABILITY = 0.25
"""Default coefficient of variation of TEC about the IRI monthly median (Rishbeth & Mendillo 2001)."""


def lognormal_nodes(cv: float, n: int) -> np.ndarray:
    """``n`` equally weighted factors X (median 1) representing a log-normal with coefficient of variation
    ``cv``. ``cv = 0`` gives ``n`` ones."""
    if cv < 0 or not np.isfinite(cv):
        raise PhysicsInputError(f"TEC variability must be a finite value >= 0, got {cv}")
    if n < 1:
        raise PhysicsInputError(f"need at least one variability node, got {n}")
    if cv == 0 or n == 1:
        return np.ones(n)
    s = np.sqrt(np.log1p(cv**2))
    from scipy import special  # imported here: scipy.stats costs a second at start-up

    z = special.ndtri((np.arange(n) + 0.5) / n)
    z *= 1.0 / np.sqrt(np.mean(z**2))
    return np.exp(s * z)
