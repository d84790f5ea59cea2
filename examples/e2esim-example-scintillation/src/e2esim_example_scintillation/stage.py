"""A new stage kind, ``scintillation``: how strongly the ionosphere makes the amplitude scintillate."""

from __future__ import annotations

from e2esim.module import Stage, fail
from e2esim.params import Param
from e2esim_example_scintillation.products import SCINTILLATION, Scintillation

WEAK_SCATTERING_EXPONENT = 1.5
"""S4 scales as f^-1.5 in weak scattering (Yeh & Liu 1982, Proc. IEEE 70(4), 324-360)."""


class S4Scintillation(Stage):
    """A given S4 index (optionally stated at another frequency and scaled to the radar's) and the number of
    independent scintillation patterns a backscatter estimate averages."""

    kind = "scintillation"
    type_name = "s4_index"
    summary = "amplitude scintillation of given S4 index, averaged over independent patterns (example plug-in)"
    params = (
        Param("s4", "float", "scintillation index S4 (normalised intensity SD) of one pattern", default=0.3,
              minimum=0.0, maximum=1.0),
        Param("independent_patterns", "int", "independent scintillation patterns averaged into one estimate",
              default=100, minimum=1, maximum=10**9),
        Param("at_frequency_mhz", "float", "frequency the S4 is stated at; scaled to the radar's as f^-1.5 "
              "(weak scattering). null: at the radar frequency", default=None, unit="MHz", exclusive_minimum=0.0,
              nullable=True),
    )
    uses = ("instrument",)
    provides = (SCINTILLATION,)

    def forward(self, case):
        s4 = self.si["s4"]
        given = self.si["at_frequency_hz"]
        if given is not None:
            if "instrument" not in case:
                raise fail(self, "needs the instrument's frequency", "add an instrument, or at_frequency_mhz: null",
                           key="at_frequency_mhz")
            s4 = min(1.0, s4 * (given / case["instrument"].centre_frequency_hz) ** WEAK_SCATTERING_EXPONENT)
        return {"ionosphere.scintillation": Scintillation(s4, self.si["independent_patterns"])}
