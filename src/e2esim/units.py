"""Unit conversions used at the YAML edge: decibels, degrees and system-error level conventions.

Inside e2esim everything is SI and radians; dB and degrees appear only in parameter names ending in
``_db`` and ``_deg``.
"""

from __future__ import annotations

import numpy as np

SIGMA = "m^2/m^2"
SIGMA_SQUARED = "(m^2/m^2)^2"
DIMENSIONLESS = "1"
COUNT = "count"
"""Units of output scalars that do not carry their unit in their name (``e2esim.products.Product.units``)."""

THREE_SIGMA_AMPLITUDE = "three_sigma_amplitude"
VARIANCE = "variance"
LEVEL_CONVENTIONS = (THREE_SIGMA_AMPLITUDE, VARIANCE)
"""How a crosstalk or channel-imbalance level in dB maps to the variance V of a zero-mean circular
complex Gaussian error term (docs/conventions.md):

* ``three_sigma_amplitude``: the label of Men et al. (2021), Section V-B and Appendix B,
  ``level_dB = 10 log10((3 sigma)^2) = 10 log10(9 V / 2)``, sigma being the SD of the real and of the
  imaginary part. The amplitude exceeds this level with probability exp(-4.5) = 0.0111 (eq. 20).
  It is the natural reading of an industry specification "|delta| < -30 dB".
* ``variance``: ``level_dB = 10 log10(V)`` (V = E|delta|^2, the mean power of the error term).
"""

_THREE_SIGMA_FACTOR = 9.0 / 2.0  # (3 sigma)^2 = 9 V / 2 because V = 2 sigma^2 (Men et al. 2021, App. B)


def db_to_linear(value_db):
    """Power ratio from decibels: ``10**(dB/10)``."""
    return 10.0 ** (np.asarray(value_db, dtype=float) / 10.0)


def linear_to_db(value):
    """Decibels from a power ratio: ``10 log10(value)``."""
    return 10.0 * np.log10(np.asarray(value, dtype=float))


def variance_from_level_db(level_db, convention: str):
    """Variance V of a complex error term from its level in dB under ``convention``."""
    if convention == THREE_SIGMA_AMPLITUDE:
        return db_to_linear(level_db) / _THREE_SIGMA_FACTOR
    if convention == VARIANCE:
        return db_to_linear(level_db)
    raise ValueError(f"unknown level convention {convention!r}; expected one of {LEVEL_CONVENTIONS}")


def level_db_from_variance(variance, convention: str):
    """Inverse of ``variance_from_level_db``."""
    if convention == THREE_SIGMA_AMPLITUDE:
        return linear_to_db(_THREE_SIGMA_FACTOR * np.asarray(variance, dtype=float))
    if convention == VARIANCE:
        return linear_to_db(variance)
    raise ValueError(f"unknown level convention {convention!r}; expected one of {LEVEL_CONVENTIONS}")
