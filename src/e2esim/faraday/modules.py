"""Ionosphere modules that give the Faraday-rotation distribution directly (kind ``ionosphere``).

The climatology modules of the orbit/ionosphere issue produce an ``EmpiricalFaraday`` the same way.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from e2esim.faraday.distribution import ConstantFaraday, EmpiricalFaraday, GaussianFaraday
from e2esim.io.samples import read_samples_file
from e2esim.module import Module
from e2esim.params import Param
from e2esim.errors import ConfigError, PhysicsInputError


_AT_FREQUENCY = Param(
    "at_frequency_mhz", "float",
    "radar frequency at which the angles are given; they are scaled by (f_given / f_radar)^2 to the "
    "instrument's centre frequency (Faraday rotation goes as 1/f^2, Quegan et al. 2018 eq. 3). "
    "null: given at the instrument's frequency", default=None, unit="MHz", exclusive_minimum=0.0, nullable=True)


def _frequency_scale(module, state) -> float:
    """(f_given / f_radar)^2, or 1 when the angles are given at the radar frequency."""
    given = module.config["at_frequency_mhz"]
    if given is None:
        return 1.0
    if state.instrument is None:
        raise ConfigError(module.location.child("at_frequency_mhz"), "needs an instrument with a centre frequency",
                          "add an instrument section, or set at_frequency_mhz: null")
    return (given * 1e6 / state.instrument.centre_frequency_hz) ** 2


class GaussianFaradayModule(Module):
    """Omega ~ N(mean, SD^2), Men et al. (2021), Section III item 4 and eq. (10)."""

    kind = "ionosphere"
    type_name = "gaussian_faraday"
    summary = "Gaussian one-way Faraday rotation with given mean and SD (Men et al. 2021, eq. 10)"
    params = (
        Param("mean_deg", "float", "mean one-way Faraday rotation", default=0.0, unit="deg",
              minimum=-180.0, maximum=180.0),
        Param("sd_deg", "float", "standard deviation of the one-way Faraday rotation", default=0.0,
              unit="deg", minimum=0.0, maximum=180.0),
        _AT_FREQUENCY,
    )
    provides = ("faraday",)

    def forward(self, state):
        k = _frequency_scale(self, state)
        fr = GaussianFaraday(k * np.radians(self.config["mean_deg"]), k * np.radians(self.config["sd_deg"]))
        return state.with_(faraday=fr)


class ConstantFaradayModule(Module):
    """A fixed one-way Faraday rotation angle."""

    kind = "ionosphere"
    type_name = "constant_faraday"
    summary = "fixed one-way Faraday rotation angle"
    params = (
        Param("value_deg", "float", "one-way Faraday rotation", default=0.0, unit="deg",
              minimum=-180.0, maximum=180.0),
        _AT_FREQUENCY,
    )
    provides = ("faraday",)

    def forward(self, state):
        k = _frequency_scale(self, state)
        return state.with_(faraday=ConstantFaraday(k * np.radians(self.config["value_deg"])))


class FaradaySamplesModule(Module):
    """Omega given by samples: a list in the scenario, or a text/.npy file of values in degrees."""

    kind = "ionosphere"
    type_name = "faraday_samples"
    summary = "empirical one-way Faraday rotation distribution from samples (list or file, degrees)"
    params = (
        Param("samples_deg", "float", "one-way Faraday rotation samples", default=None, unit="deg",
              variable_length=True, nullable=True),
        Param("samples_file", "str", "text or .npy file of samples in degrees, relative to the scenario file",
              default=None, nullable=True),
    )
    provides = ("faraday",)

    def setup(self):
        values, path = self.config["samples_deg"], self.config["samples_file"]
        if (values is None) == (path is None):
            raise PhysicsInputError("give exactly one of samples_deg and samples_file")
        if path is not None:
            base = Path(self.location.source).parent if Path(self.location.source).exists() else Path(".")
            file = (base / path) if not Path(path).is_absolute() else Path(path)
            values = read_samples_file(file, key="samples_file")
        self.distribution = EmpiricalFaraday(np.radians(np.asarray(values, dtype=float)), label="samples")

    def forward(self, state):
        return state.with_(faraday=self.distribution)
