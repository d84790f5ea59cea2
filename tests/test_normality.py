"""Normality statistics written without scipy.stats (e2esim.distortion.normality) against scipy.stats."""

import numpy as np
import pytest
from scipy import stats

from e2esim.distortion import normality


def _samples(rng):
    return {
        "gaussian": 0.02 + 1e-3 * rng.standard_normal(4000),
        "gamma": rng.gamma(2.0, size=5000),
        "student_t": rng.standard_t(5, 300),
        "uniform_small": rng.uniform(size=20),
    }


@pytest.mark.parametrize("name", ["gaussian", "gamma", "student_t", "uniform_small"])
def test_statistics_equal_scipy(rng, name):
    x = _samples(rng)[name]
    mu, sd = x.mean(), x.std(ddof=1)
    assert normality.skewness(x) == pytest.approx(stats.skew(x), rel=1e-12)
    assert normality.kurtosis(x) - 3 == pytest.approx(stats.kurtosis(x), rel=1e-12)
    assert normality.skewness_z(x) == pytest.approx(stats.skewtest(x).statistic, rel=1e-12)
    assert normality.kurtosis_z(x) == pytest.approx(stats.kurtosistest(x).statistic, rel=1e-12)
    assert normality.normaltest_pvalue(x) == pytest.approx(stats.normaltest(x).pvalue, rel=1e-10)
    assert normality.ks_distance_normal(x, mu, sd) == pytest.approx(stats.kstest(x, "norm", args=(mu, sd)).statistic,
                                                                     rel=1e-12)


def test_known_values():
    # {0, 0, 0, 1}: m2 = 3/16, m3 = 3/32, m4 = 21/256, so skewness 2/sqrt(3), kurtosis 7/3
    x = np.array([0.0, 0.0, 0.0, 1.0])
    assert normality.skewness(x) == pytest.approx(2 / np.sqrt(3), rel=1e-14)
    assert normality.kurtosis(x) == pytest.approx(7 / 3, rel=1e-14)
    # one point at the mean of N(0, 1): D = max(1 - 0.5, 0.5 - 0) = 0.5
    assert normality.ks_distance_normal(np.array([0.0]), 0.0, 1.0) == pytest.approx(0.5, rel=1e-15)


def test_a_constant_sample_has_no_shape():
    x = np.full(50, 3.0)
    assert np.isnan(normality.skewness(x)) and np.isnan(normality.kurtosis(x))
