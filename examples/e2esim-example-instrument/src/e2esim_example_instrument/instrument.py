"""An L-band instrument whose polarimetric errors scale with its calibration quality.

It subclasses e2esim's Gaussian-error instrument, declares its own parameters once (they validate the
YAML section, the Python call and appear in ``e2esim modules``), and derives the crosstalk and
channel-imbalance levels from a single "calibration grade" -- the kind of coupling a system engineer may
want to explore. It does so in ``derive``, the hook for derived parameters: the configuration stays as the
user gave it, so the module passes ``e2esim.testing.check_module``. Everything else (sampling, analytic
statistics, reports) comes from e2esim.
"""

from __future__ import annotations

from e2esim.instrument.modules import GaussianErrorsInstrument
from e2esim.params import Param, with_defaults

_GRADE_LEVELS_DB = {  # (crosstalk, channel imbalance), 3-sigma amplitude labels
    "excellent": (-35.0, -38.0),
    "nominal": (-30.0, -34.0),
    "degraded": (-25.0, -30.0),
}


class ExampleLBandInstrument(GaussianErrorsInstrument):
    """L-band polarimetric SAR (1.257 GHz, 20 MHz, NESZ -25 dB) with errors set by a calibration grade."""

    type_name = "example_lband"
    summary = "example plug-in: L-band SAR whose crosstalk/channel imbalance follow a calibration grade"
    params = with_defaults(
        GaussianErrorsInstrument.params,
        {
            "name": "example L-band SAR",
            "crosstalk.level_db": None,
            "crosstalk.correlation_magnitude": 0.5,
            "channel_imbalance.level_db": None,
            "channel_imbalance.correlation_magnitude": 0.5,
            "nesz_db": -25.0,
            "centre_frequency_mhz": 1257.0,
            "bandwidth_mhz": 20.0,
        },
    ) + (
        Param("calibration_grade", "str", "sets crosstalk and channel imbalance when their levels are null",
              default="nominal", choices=tuple(_GRADE_LEVELS_DB)),
    )

    def derive(self, si):
        """Levels left null take the grade's; then the instrument derives their variances as usual."""
        crosstalk_db, imbalance_db = _GRADE_LEVELS_DB[si["calibration_grade"]]
        for group, level in (("crosstalk", crosstalk_db), ("channel_imbalance", imbalance_db)):
            if si[group]["level_db"] is None:
                si[group] = {**si[group], "level_db": level}
        return super().derive(si)
