"""How close a sample is to a Gaussian: skewness, excess kurtosis, the D'Agostino-Pearson test and the
Kolmogorov-Smirnov distance (the statistics of Men et al. 2021, Fig. 2, that ``montecarlo.gaussianity`` reports).

Written with numpy and ``scipy.special`` rather than ``scipy.stats``, whose import costs about two seconds of
every Monte Carlo run; the formulas and their order of operations are those of ``scipy.stats`` (``skew``,
``kurtosis``, ``skewtest``, ``kurtosistest``, ``normaltest``, ``kstest``), so the numbers agree with it
(tests/test_normality.py).
"""

from __future__ import annotations

import numpy as np


def central_moments(x: np.ndarray) -> tuple:
    """Biased central moments (m2, m3, m4) of a 1-D sample; m2 is NaN when the sample is constant to rounding
    (then no shape statistic is defined)."""
    mean = np.mean(x)
    d = x - mean
    d2 = d**2
    m2 = np.mean(d2)
    if m2 <= (np.finfo(float).eps * mean) ** 2:
        m2 = np.nan
    return m2, np.mean(d2 * d), np.mean(d2**2)


def skewness(x: np.ndarray) -> float:
    """Sample skewness ``sqrt(b1) = m3 / m2^(3/2)`` (biased moments; D'Agostino et al. 1990, eq. 1)."""
    m2, m3, _ = central_moments(x)
    return float(m3 / m2**1.5)


def kurtosis(x: np.ndarray) -> float:
    """Sample kurtosis ``b2 = m4 / m2^2`` (D'Agostino et al. 1990, eq. 2); 3 for a Gaussian."""
    m2, _, m4 = central_moments(x)
    return float(m4 / m2**2.0)


def skewness_z(x: np.ndarray) -> float:
    """Normal score of the sample skewness, D'Agostino's transformation (D'Agostino, Belanger & D'Agostino
    1990, "A suggestion for using powerful and informative tests of normality", The American Statistician
    44(4), 316-321, eqs. 4-11 (first Johnson SU approximation); n >= 8)."""
    n = float(x.size)
    y = skewness(x) * np.sqrt(((n + 1) * (n + 3)) / (6.0 * (n - 2)))
    beta2 = 3.0 * (n**2 + 27 * n - 70) * (n + 1) * (n + 3) / ((n - 2.0) * (n + 5) * (n + 7) * (n + 9))
    w2 = -1 + np.sqrt(2 * (beta2 - 1))
    delta = 1 / np.sqrt(0.5 * np.log(w2))
    alpha = np.sqrt(2.0 / (w2 - 1))
    y = 1.0 if y == 0 else y
    return float(delta * np.log(y / alpha + np.sqrt((y / alpha) ** 2 + 1)))


def kurtosis_z(x: np.ndarray) -> float:
    """Normal score of the sample kurtosis b2 (Anscombe & Glynn 1983, "Distribution of the kurtosis statistic
    b2 for normal samples", Biometrika 70(1), 227-234; as D'Agostino et al. 1990, eqs. 12-19; n >= 5)."""
    n = float(x.size)
    b2 = kurtosis(x)
    e = 3.0 * (n - 1) / (n + 1)
    varb2 = 24.0 * n * (n - 2) * (n - 3) / ((n + 1) * (n + 1.0) * (n + 3) * (n + 5))
    z = (b2 - e) / varb2**0.5
    sqrtbeta1 = (6.0 * (n * n - 5 * n + 2) / ((n + 7) * (n + 9))
                 * ((6.0 * (n + 3) * (n + 5)) / (n * (n - 2) * (n - 3))) ** 0.5)
    a = 6.0 + 8.0 / sqrtbeta1 * (2.0 / sqrtbeta1 + (1 + 4.0 / (sqrtbeta1**2)) ** 0.5)
    term1 = 1 - 2 / (9.0 * a)
    denom = 1 + z * (2 / (a - 4.0)) ** 0.5
    if denom == 0:
        return float("nan")
    term2 = np.sign(denom) * ((1 - 2.0 / a) / np.abs(denom)) ** (1 / 3)
    return float((term1 - term2) / (2 / (9.0 * a)) ** 0.5)


def normaltest_pvalue(x: np.ndarray) -> float:
    """p-value of the D'Agostino-Pearson omnibus test: ``K^2 = Z(sqrt b1)^2 + Z(b2)^2`` against chi-square with
    2 degrees of freedom (D'Agostino et al. 1990, eq. 20; D'Agostino & Pearson 1973, Biometrika 60, 613-622)."""
    from scipy import special

    k2 = skewness_z(x) ** 2 + kurtosis_z(x) ** 2
    return float(special.chdtrc(2.0, k2))


def ks_distance_normal(x: np.ndarray, mean: float, sd: float) -> float:
    """Kolmogorov-Smirnov distance ``sup |F_n(x) - Phi((x - mean) / sd)|`` between the sample's empirical
    distribution and a Gaussian (the larger of D+ and D-, Kolmogorov 1933)."""
    from scipy import special

    x = np.sort(x)
    n = x.size
    cdf = special.ndtr((x - mean) / sd)
    d_plus = np.max(np.arange(1.0, n + 1) / n - cdf)
    d_minus = np.max(cdf - np.arange(0.0, n) / n)
    return float(max(d_plus, d_minus))
