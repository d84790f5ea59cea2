"""Instrument modules (kind ``instrument``): system-error statistics, noise and gain of the radar.

Levels are given in dB with an explicit convention (``e2esim.units.LEVEL_CONVENTIONS``); the pair
correlations of Men et al. (2021), Section III, may take any magnitude and phase, and the variances of
the individual terms may differ (``term_offsets_db``).
"""

from __future__ import annotations

import numpy as np

from e2esim import products as P
from e2esim.instrument.description import InstrumentDescription
from e2esim.instrument.system_errors import SystemErrorModel
from e2esim.module import Stage
from e2esim.params import Param, ParamGroup, with_defaults
from e2esim.units import LEVEL_CONVENTIONS, THREE_SIGMA_AMPLITUDE, variance_from_level_db


def _error_group(name: str, what: str, terms: str, n_terms: int, extra: tuple = ()) -> ParamGroup:
    return ParamGroup(
        name,
        f"{what} terms {terms}: zero-mean circular complex Gaussian (Men et al. 2021, Section III)",
        (
            Param("level_db", "float", f"{what} level (null: no {what}); its variance follows the convention",
                  unit="dB", minimum=-200.0, maximum=0.0, nullable=True, convert=False),
            Param("convention", "str", "how level_db maps to the variance V of each term (docs/conventions.md)",
                  default=THREE_SIGMA_AMPLITUDE, choices=LEVEL_CONVENTIONS),
            Param("term_offsets_db", "float", f"offset of each of {terms} from level_db (unequal variances)",
                  default=(0.0,) * n_terms, unit="dB", length=n_terms, minimum=-100.0, maximum=100.0),
            Param("correlation_magnitude", "float", f"|rho| of the correlated {what} pair", default=0.0,
                  minimum=0.0, maximum=1.0),
            Param("correlation_phase_deg", "float", f"phase of rho of the correlated {what} pair", default=0.0,
                  unit="deg", minimum=-180.0, maximum=180.0),
        )
        + extra,
    )


_CROSSTALK = _error_group(
    "crosstalk",
    "crosstalk",
    "delta_1..delta_4",
    4,
    extra=(
        Param("correlation_24_magnitude", "float", "|rho_24| if it differs from |rho_13| (null: the same)",
              default=None, minimum=0.0, maximum=1.0, nullable=True),
        Param("correlation_24_phase_deg", "float", "phase of rho_24 if it differs (null: the same)",
              default=None, unit="deg", minimum=-180.0, maximum=180.0, nullable=True),
    ),
)
_IMBALANCE = _error_group("channel_imbalance", "channel imbalance", "epsilon_1, epsilon_2 (f_i = 1 + epsilon_i)", 2)


class GaussianErrorsInstrument(Stage):
    """A polarimetric radar with jointly Gaussian crosstalk and channel imbalance, noise and gain error."""

    kind = "instrument"
    type_name = "gaussian_errors"
    summary = "Gaussian crosstalk/channel-imbalance statistics with pair correlations, NESZ and gain error"
    params = (
        Param("name", "str", "instrument label for reports", default="instrument"),
        _CROSSTALK,
        _IMBALANCE,
        Param("nesz_db", "float", "noise-equivalent sigma zero (null: no noise)", unit="dB", minimum=-200.0,
              maximum=20.0, nullable=True),
        Param("gain_offset_db", "float", "absolute gain error |A|^2, mean (Gaussian in dB)", default=0.0, unit="dB",
              minimum=-20.0, maximum=20.0, convert=False),
        Param("gain_sd_db", "float", "absolute gain error |A|^2, SD (Gaussian in dB)", default=0.0, unit="dB",
              minimum=0.0, maximum=20.0, convert=False),
        Param("centre_frequency_mhz", "float", "radar centre frequency", unit="MHz", exclusive_minimum=0.0),
        Param("bandwidth_mhz", "float", "radar bandwidth", unit="MHz", exclusive_minimum=0.0),
    )
    provides = (P.SYSTEM, P.INSTRUMENT)

    def derive(self, si: dict) -> dict:
        """Adds the variances V_delta and V_eps of the error terms (``crosstalk_variance``,
        ``imbalance_variance``) from each level in dB and its convention (docs/conventions.md)."""
        si = super().derive(si)
        si["crosstalk_variance"] = _variance(si["crosstalk"])
        si["imbalance_variance"] = _variance(si["channel_imbalance"])
        return si

    def setup(self):
        self.model = system_error_model(self.si)
        xt, ci = self.si["crosstalk"], self.si["channel_imbalance"]
        self.description = InstrumentDescription(
            name=self.si["name"],
            crosstalk_db=_db_or_off(xt["level_db"]),
            imbalance_db=_db_or_off(ci["level_db"]),
            convention=xt["convention"] if xt["convention"] == ci["convention"] else "mixed",
            nesz_db=_db_or_off(self.config["nesz_db"] if "nesz_db" in self.config else None),  # a subclass may drop it
            centre_frequency_hz=self.si["centre_frequency_hz"],
            bandwidth_hz=self.si["bandwidth_hz"],
        )

    def forward(self, case):
        return {"system": self.model, "instrument": self.description}


def system_error_model(si) -> SystemErrorModel:
    """``SystemErrorModel`` from the SI values of a ``gaussian_errors`` instrument (``Module.si``)."""
    xt, ci = si["crosstalk"], si["channel_imbalance"]
    rho13 = xt["correlation_magnitude"] * np.exp(1j * xt["correlation_phase_rad"])
    mag24 = xt["correlation_24_magnitude"]
    phase24 = xt["correlation_24_phase_rad"]
    rho24 = (xt["correlation_magnitude"] if mag24 is None else mag24) * np.exp(
        1j * (xt["correlation_phase_rad"] if phase24 is None else phase24)
    )
    rho_eps = ci["correlation_magnitude"] * np.exp(1j * ci["correlation_phase_rad"])
    return SystemErrorModel(
        crosstalk_level=si["crosstalk_variance"],
        crosstalk_relative=xt["term_offsets_linear"],
        crosstalk_rho13=rho13,
        crosstalk_rho24=rho24,
        imbalance_level=si["imbalance_variance"],
        imbalance_relative=ci["term_offsets_linear"],
        imbalance_rho=rho_eps,
        noise_power=0.0 if si["nesz_linear"] is None else si["nesz_linear"],
        gain_offset_db=si["gain_offset_db"],
        gain_sd_db=si["gain_sd_db"],
    )


def _variance(group: dict) -> float:
    return 0.0 if group["level_db"] is None else float(variance_from_level_db(group["level_db"], group["convention"]))


def _db_or_off(value):
    return float("-inf") if value is None else float(value)


class BiomassInstrument(GaussianErrorsInstrument):
    """ESA BIOMASS P-band SAR: specification values as defaults.

    Crosstalk < -30 dB and channel imbalance < -34 dB (Quegan et al. 2018, Section 5; Men et al. 2021,
    Section VI), read as 3-sigma amplitudes (Men et al. 2021, Section V-B); pair correlations 0.9 with
    phase 0, the most stringent case (Men et al. 2021, Section IV); NESZ -27 dB (threshold; Men et al.
    2021, Section V-A, Table III); 435 MHz (Quegan et al. 2018, Section 5), 6 MHz bandwidth (WMO OSCAR
    instrument "SAR-P").
    """

    type_name = "biomass"
    summary = "ESA BIOMASS P-band preset: crosstalk -30 dB, channel imbalance -34 dB (3-sigma), NESZ -27 dB, 435 MHz"
    params = with_defaults(
        GaussianErrorsInstrument.params,
        {
            "name": "BIOMASS",
            "crosstalk.level_db": -30.0,
            "crosstalk.correlation_magnitude": 0.9,
            "channel_imbalance.level_db": -34.0,
            "channel_imbalance.correlation_magnitude": 0.9,
            "nesz_db": -27.0,
            "centre_frequency_mhz": 435.0,
            "bandwidth_mhz": 6.0,
        },
    )


class NisarInstrument(GaussianErrorsInstrument):
    """NASA-ISRO NISAR L-band SAR, a second instrument preset.

    1.257 GHz centre frequency and NESZ -25 dB (NISAR Science Users' Handbook, NASA/JPL 2019), 20 MHz of the
    selectable 5-80 MHz (NISAR calibration and validation plan, URSI AP-RASC 2019, abstract). NISAR's
    polarimetric distortion specification is not among the published facts e2esim has, so crosstalk and
    channel imbalance keep the BIOMASS values (-30 dB and -34 dB,
    3-sigma labels, rho = 0.9): a comparison with BIOMASS then isolates the effect of frequency (Faraday
    rotation about (1257/435)^2 = 8.4 times smaller) and noise. Override them when the specification is known.
    """

    type_name = "nisar"
    summary = "NASA-ISRO NISAR L-band preset: 1257 MHz, 20 MHz, NESZ -25 dB; distortion levels as BIOMASS"
    params = with_defaults(BiomassInstrument.params,  # the distortion levels stay BIOMASS's
                           {"name": "NISAR", "nesz_db": -25.0, "centre_frequency_mhz": 1257.0, "bandwidth_mhz": 20.0})
