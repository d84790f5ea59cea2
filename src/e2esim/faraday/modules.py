"""Ionosphere modules that give the Faraday-rotation distribution directly (kind ``ionosphere``).

The climatology modules of the orbit/ionosphere issue produce an ``EmpiricalFaraday`` the same way.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from e2esim import products as P
from e2esim.faraday.distribution import ConstantFaraday, EmpiricalFaraday, GaussianFaraday
from e2esim.faraday.samples_file import read_samples_file
from e2esim.module import Stage, fail
from e2esim.params import ExactlyOneOf, Param

_AT_FREQUENCY = Param(
    "at_frequency_mhz", "float",
    "radar frequency at which the angles are given; they are scaled by (f_given / f_radar)^2 to the "
    "instrument's centre frequency (Faraday rotation goes as 1/f^2, Quegan et al. 2018 eq. 3). "
    "null: given at the instrument's frequency", default=None, unit="MHz", exclusive_minimum=0.0, nullable=True)


def _angle_param(name: str, description: str, minimum: float) -> Param:
    """A one-way Faraday-rotation angle of the distribution, in degrees at the YAML edge (0 by default, at most
    180 deg in size)."""
    return Param(name, "float", description, default=0.0, unit="deg", minimum=minimum, maximum=180.0)


def _frequency_scale(module, case) -> float:
    """(f_given / f_radar)^2, or 1 when the angles are given at the radar frequency."""
    given = module.si["at_frequency_hz"]
    if given is None:
        return 1.0
    if "instrument" not in case:
        raise fail(module, "needs an instrument with a centre frequency",
                   "add an instrument section, or set at_frequency_mhz: null", key="at_frequency_mhz")
    return (given / case["instrument"].centre_frequency_hz) ** 2


class _FaradayStage(Stage):
    """Shared declarations of the modules that state the Faraday-rotation distribution directly."""

    kind = "ionosphere"
    uses = ("instrument",)
    provides = (P.FARADAY,)


class GaussianFaradayModule(_FaradayStage):
    """Omega ~ N(mean, SD^2), Men et al. (2021), Section III item 4 and eq. (10)."""

    type_name = "gaussian_faraday"
    summary = "Gaussian one-way Faraday rotation with given mean and SD (Men et al. 2021, eq. 10)"
    params = (
        _angle_param("mean_deg", "mean one-way Faraday rotation", -180.0),
        _angle_param("sd_deg", "standard deviation of the one-way Faraday rotation", 0.0),
        _AT_FREQUENCY,
    )

    def forward(self, case):
        k = _frequency_scale(self, case)
        return {"faraday.geophysical": GaussianFaraday(k * self.si["mean_rad"], k * self.si["sd_rad"])}


class ConstantFaradayModule(_FaradayStage):
    """A fixed one-way Faraday rotation angle."""

    type_name = "constant_faraday"
    summary = "fixed one-way Faraday rotation angle"
    params = (
        _angle_param("value_deg", "one-way Faraday rotation", -180.0),
        _AT_FREQUENCY,
    )

    def forward(self, case):
        k = _frequency_scale(self, case)
        return {"faraday.geophysical": ConstantFaraday(k * self.si["value_rad"])}


class FaradaySamplesModule(_FaradayStage):
    """Omega given by samples: a list in the scenario, or a text/.npy file of values in degrees."""

    type_name = "faraday_samples"
    summary = "empirical one-way Faraday rotation distribution from samples (list or file, degrees)"
    params = (
        Param("samples_deg", "float", "one-way Faraday rotation samples", default=None, unit="deg",
              variable_length=True, nullable=True),
        Param("samples_file", "str", "text or .npy file of samples in degrees, relative to the scenario file",
              default=None, nullable=True, input_file=True),
        ExactlyOneOf("samples_deg", "samples_file"),
    )
    uses = ()

    def setup(self):
        values, path = self.config["samples_deg"], self.si["samples_file"]
        if path is not None:
            base = Path(self.location.source).parent if Path(self.location.source).exists() else Path(".")
            file = (base / path) if not Path(path).is_absolute() else Path(path)
            values = read_samples_file(file, key="samples_file")
        self.distribution = EmpiricalFaraday(np.radians(np.asarray(values, dtype=float)), label="samples")

    def forward(self, case):
        return {"faraday.geophysical": self.distribution}
