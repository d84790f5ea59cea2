"""The ``rfi`` error term: radio-frequency interference in the P-band window and what its mitigation leaves
(docs/theory/rfi.md).

BIOMASS transmits 6 MHz in the 432-438 MHz window, which it shares with radiolocation (primary) and the amateur and
amateur-satellite services (ITU Radio Regulations, Article 5, footnote 5.279A; Quegan et al. 2018). Mitigation
removes part of the band (notch filtering, a fraction f_b) and of the time (pulse blanking, a fraction f_t), and
leaves some interference unremoved. One term makes three sources, each its own level and attribution:

* ``<source>_notch``: the energy the notch and the blanking remove, g = g_b (1 - f_t), with g_b the notched spectrum's
  energy ratio (``e2esim.error_terms.notch``; 1 - f_b for a binary notch): an intensity factor g on every channel
  (``FixedGain``, level 1 - g) unless the processor restores it (``compensated``), since a distributed target's
  mean intensity is the integral of its processed spectrum (Parseval);
* ``<source>_looks``: fewer independent samples, L' = L eta (1 - f_t), eta the looks factor of the notched spectrum:
  speckle of relative variance 1/L' instead of 1/L, the excess r^2 = 1/L' - 1/L added as a zero-mean error
  (``ExtraVariance``; Goodman 2007, Chapter 4, for the variance of an L-look intensity);
* ``<source>_residual``: interference left after mitigation, a noise power N_rfi (as a backscattering coefficient,
  like an NESZ) in each of the L' looks (``AddedPower``; Ahmed et al. 2014, eq. 21): the SNR falls from
  sigma/NESZ to sigma/(NESZ + N_rfi). The notch itself removes signal and noise alike and leaves the SNR as it was.

The affected fraction is given, or read per cell from a user's raster (``fraction_map``: a NetCDF variable over
lat and lon, ``e2esim.scene.lat_lon_raster``) at the term's ``lat_deg``/``lon_deg`` or, in a map sweep, at the
case's cell. The notched impulse response's point-target metrics (peak loss, 3-dB resolution, PSLR, ISLR) are
reported as output scalars ``error_term.<source>.*``: they concern calibrators and point targets, not the
distributed-target error the requirement checks.
"""

from __future__ import annotations

from e2esim.error_terms.effects import AddedPower, ExtraVariance, FixedGain
from e2esim.error_terms.modules import MAP_CELL_KEYS, ErrorTerm, source_param
from e2esim.error_terms.notch import POSITIONS, notch_response
from e2esim.input_files import scenario_relative
from e2esim.module import fail
from e2esim.params import AtMostOneOf, Param
from e2esim.scene.lat_lon_raster import read_lat_lon_raster

CELL_KEYS = (MAP_CELL_KEYS["lat"], MAP_CELL_KEYS["lon"])
"""The sweep keys of a map sweep's cell, where a ``fraction_map`` is looked up when the term gives no point."""


class RFITerm(ErrorTerm):
    """RFI left by mitigation: the notch's energy loss, the lost looks and the residual interference (module
    docstring)."""

    type_name = "rfi"
    summary = "RFI after mitigation: band/time removed (gain loss, fewer looks) and residual interference power"
    params = (
        Param("band_fraction_percent", "float", "share f_b of the 6 MHz band removed by notch filtering (or that of "
              "fraction_map; null: 0)", default=None, nullable=True, unit="%", minimum=0.0, exclusive_maximum=100.0),
        Param("time_fraction_percent", "float", "share f_t of the pulses (of the aperture time) blanked",
              default=0.0, unit="%", minimum=0.0, exclusive_maximum=100.0),
        Param("notch_position", "str", "where the notch sits in the band: centre or edge (changes the impulse "
              "response, not the energy or the looks)", default="centre", choices=POSITIONS),
        Param("compensated", "bool", "the processor restores the energy the notch and the blanking remove (no gain "
              "loss; the lost looks and the residual stay)", default=False),
        Param("residual_power_db", "float", "interference power left after mitigation, as a backscattering "
              "coefficient like an NESZ (null: none left)", default=None, nullable=True, unit="dB"),
        Param("looks", "int", "L: independent samples of the estimate without RFI (null: the simulation's looks); "
              "give the random-error budget's looks when the chain has one", default=None, nullable=True,
              minimum=1),
        Param("fraction_map", "str", "NetCDF file of the band fraction f_b (0-1) per lat/lon pixel, variable "
              "fraction_map_variable over lat and lon; looked up at lat_deg/lon_deg or at a map sweep's cell",
              default=None, nullable=True, input_file=True),
        Param("fraction_map_variable", "str", "the variable of fraction_map", default="band_fraction"),
        Param("lat_deg", "float", "latitude where fraction_map is read (null: the map sweep's cell)", default=None,
              nullable=True, unit="deg", minimum=-90.0, maximum=90.0, convert=False),
        Param("lon_deg", "float", "longitude where fraction_map is read (null: the map sweep's cell)", default=None,
              nullable=True, unit="deg", minimum=-180.0, maximum=360.0, convert=False),
        source_param("rfi"),
        AtMostOneOf("band_fraction_percent", "fraction_map"),
    )

    def setup(self) -> None:
        super().setup()
        c = self.si
        self.raster = None
        self._made: dict = {}  # the effects by (band fraction, time fraction, looks): ``effects``
        # the notched response of a fixed fraction, once per module (one per distinct configuration of a sweep)
        self.notch = None if c["fraction_map"] else notch_response(c["band_fraction_fraction"] or 0.0,
                                                                     c["notch_position"])
        if c["fraction_map"]:
            path = scenario_relative(c["fraction_map"], self.location.source)
            self.raster = read_lat_lon_raster(path, c["fraction_map_variable"], "RFI fraction map", 0.0, 1.0,
                                              key="fraction_map")

    @property
    def sources(self) -> tuple:
        return tuple(f"{self.source}_{part}" for part in ("notch", "looks", "residual"))

    def band_fraction(self, case) -> float:
        """f_b of ``case``: the parameter, or the fraction map at the term's point or the case's cell."""
        if self.raster is None:
            return self.si["band_fraction_fraction"] or 0.0
        lat = self.si["lat_deg"] if self.si["lat_deg"] is not None else case.inputs.get(CELL_KEYS[0])
        lon = self.si["lon_deg"] if self.si["lon_deg"] is not None else case.inputs.get(CELL_KEYS[1])
        if lat is None or lon is None:
            raise fail(self, "a fraction_map needs a place to be read", "give lat_deg and lon_deg, or run a map "
                       "sweep", key="fraction_map")
        value = float(self.raster.lookup(lat, lon))
        if not 0.0 <= value < 1.0:
            raise fail(self, f"the fraction map {self.raster.source!r} has no band fraction below 1 at latitude "
                       f"{lat:g}, longitude {lon:g} deg (value {value!r}: no data, or the whole band removed)",
                       "give a map that covers every cell swept, with fractions from 0 to below 1",
                       key="fraction_map")
        return value

    def time_fraction(self, case) -> float:
        """f_t of ``case``: the parameter (``rfi_from_product`` reads it from a product's annotation)."""
        return self.si["time_fraction_fraction"]

    def effects(self, case) -> tuple:
        """The three effects (``FixedGain``, ``ExtraVariance``, ``AddedPower``) of ``case``: made once for each band
        fraction, time fraction and number of looks (every cell of a map without a fraction map shares them)."""
        key = (self.band_fraction(case), self.time_fraction(case), self.si["looks"] or case.settings.looks)
        if key not in self._made:
            if len(self._made) >= 4096:  # a fraction map's many values: kept bounded
                self._made.clear()
            self._made[key] = self._effects(*key)
        return self._made[key]

    def _effects(self, f_b: float, f_t: float, looks: int) -> tuple:
        c, name = self.si, self.source
        notch_source, looks_source, residual_source = self.sources
        notch = self.notch or notch_response(f_b, c["notch_position"])
        kept = notch.looks_factor * (1.0 - f_t)
        gain = notch.energy_ratio * (1.0 - f_t)
        outputs = tuple((f"error_term.{name}.{k}", float(v)) for k, v in (
            ("band_fraction", f_b), ("time_fraction", f_t), ("energy_ratio", gain), ("looks_factor", kept),
            ("peak_loss_db", notch.peak_loss_db), ("resolution_ratio", notch.resolution_ratio),
            ("pslr_db", notch.pslr_db), ("islr_db", notch.islr_db)))
        residual = c["residual_power_linear"] or 0.0
        return (FixedGain(notch_source, 0.0 if c["compensated"] else 1.0 - gain, "RFI: energy removed by the "
                          "notch and blanking, not restored", outputs=outputs),
                ExtraVariance(looks_source, 1.0 / (looks * kept) - 1.0 / looks, "RFI: speckle of the looks the "
                              "notch and blanking remove (Goodman 2007)"),
                AddedPower(residual_source, residual, "RFI: residual interference power (Ahmed et al. 2014, eq. "
                           "21)", looks=max(int(looks * kept), 1)))

    effects_take_blocks = True
    effects_ignore_model = True

    def case_effects(self, case, model) -> tuple:
        return self.effects(case)


__all__ = ["CELL_KEYS", "RFITerm"]
