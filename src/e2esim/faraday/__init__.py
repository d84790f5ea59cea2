"""Faraday rotation: distributions of the one-way rotation angle Omega and the modules giving them."""

from e2esim.faraday.distribution import (
    ConstantFaraday,
    EmpiricalFaraday,
    FaradayDistribution,
    GaussianFaraday,
)

__all__ = ["ConstantFaraday", "EmpiricalFaraday", "FaradayDistribution", "GaussianFaraday"]
