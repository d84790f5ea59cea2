"""Published values of Quegan et al. (2018), calibration part (Sections 3-5), recomputed by
``e2esim.verification.quegan2018_calibration``. The ionosphere and geolocation ids of the same paper are in
``quegan2018_values``."""

from __future__ import annotations

from e2esim.verification.records import Published

_CAL = "e2esim.verification.quegan2018_calibration"

PUBLISHED: list = [
    Published(
        "quegan2018.sec4.fr_correction_accuracy_deg",
        "accuracy to which Faraday rotation can be corrected (deg): an upper bound, met when the computed "
        "99.865 % quantile of |Omega_hat - Omega| is below it",
        1.0, 0.0,
        "Quegan et al. (2018), Section 4.2 ('readily corrected to an accuracy of better than 1 deg'), with the "
        "Bickel-Bates estimator of Section 3 (eqs. 5-6)",
        f"{_CAL}:fr_correction_accuracy", kind="upper_bound",
    ),
]
