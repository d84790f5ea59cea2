"""Calibration modules that state what calibration leaves (issue 23, item 3): ``residual_faraday`` and
``residual_system``. A requirement is flowed down to these knobs (``e2esim solve``, ``e2esim allocate``) without
modelling an estimator; they sit in the ``calibration`` list like any step (``e2esim.calibration.stated_steps``)."""

from __future__ import annotations

from e2esim.calibration.modules import CalibrationModule
from e2esim.calibration.stated_steps import ResidualFaradayStep, StatedResidualStep
from e2esim.params import Param
from e2esim.units import LEVEL_CONVENTIONS, THREE_SIGMA_AMPLITUDE, db_to_linear, variance_from_level_db


class ResidualFaraday(CalibrationModule):
    """The Faraday rotation left in the data after its correction, stated as N(bias, sd^2): what a
    ``faraday_correction`` step's estimator would leave. The symmetrised HV estimate of Men et al. (2021),
    eq. (2), is unchanged by it (a setting that changes nothing there is reported); the co-polarised channels
    (``polarimetric_error``, ``stack_backscatter_error`` with ``channels: all``) see it."""

    type_name = "residual_faraday"
    rotation_only = True
    summary = "the Faraday rotation left after correction, stated (bias and SD), instead of an estimator"
    needs = ("system", "faraday.geophysical")
    params = (
        Param("bias_deg", "float", "mean of the rotation left, Omega - Omega_hat", default=0.0, unit="deg",
              minimum=-45.0, maximum=45.0),
        Param("sd_deg", "float", "SD of the rotation left", default=0.0, unit="deg", minimum=0.0, maximum=45.0),
    )

    def steps(self, case):
        return [(self.type_name, ResidualFaradayStep(self.si["bias_rad"], self.si["sd_rad"]))]


class ResidualSystem(CalibrationModule):
    """Residual crosstalk, channel imbalance, NESZ and gain error after calibration, stated: each given level
    replaces what the steps before leave (null keeps it). The levels are in ``convention`` (docs/conventions.md),
    the NESZ and gain in dB."""

    type_name = "residual_system"
    summary = "residual crosstalk, channel imbalance, NESZ and gain after calibration, stated directly"
    needs = ("system", "faraday.geophysical")
    params = (
        Param("crosstalk_db", "float", "residual crosstalk level (null: what the steps before leave)", default=None,
              unit="dB", minimum=-200.0, maximum=0.0, nullable=True, convert=False),
        Param("channel_imbalance_db", "float", "residual channel-imbalance level (null: what the steps before leave)",
              default=None, unit="dB", minimum=-200.0, maximum=0.0, nullable=True, convert=False),
        Param("convention", "str", "how the levels map to the variance of each term (docs/conventions.md)",
              default=THREE_SIGMA_AMPLITUDE, choices=LEVEL_CONVENTIONS),
        Param("nesz_db", "float", "residual noise-equivalent sigma zero (null: the instrument's)", default=None,
              unit="dB", minimum=-200.0, maximum=20.0, nullable=True, convert=False),
        Param("gain_offset_db", "float", "residual absolute gain error |A|^2, mean (null: what the steps leave)",
              default=None, unit="dB", minimum=-20.0, maximum=20.0, nullable=True, convert=False),
        Param("gain_sd_db", "float", "residual absolute gain error |A|^2, SD (null: what the steps leave)",
              default=None, unit="dB", minimum=0.0, maximum=20.0, nullable=True, convert=False),
    )

    def steps(self, case):
        c, convention = self.config, self.config["convention"]

        def variance(db):
            return None if db is None else float(variance_from_level_db(db, convention))

        step = StatedResidualStep(variance(c["crosstalk_db"]), variance(c["channel_imbalance_db"]),
                                  None if c["nesz_db"] is None else float(db_to_linear(c["nesz_db"])),
                                  c["gain_offset_db"], c["gain_sd_db"])
        return [(self.type_name, step)]
