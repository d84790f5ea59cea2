"""The scintillation error terms (kind ``error_terms``): the radiometric consequences of ionospheric scintillation.

Each term reads the case's ``geometry`` (every acquisition: pierce point, local time, date, incidence) and, through
the climatology, the screen each acquisition sees at the term's solar activity (``acquisitions``), so a sweep or a
map sets it per case from the site, the passes, the season and the solar activity. Three terms, one consequence each
(docs/theory/scintillation.md, Section 5):

* ``scintillation_sigma0``: sigma0 of a distributed target (energy moved out of the product cell; eq. S19);
* ``scintillation_calibration``: the gain error a point calibrator seen through the screen leaves (eq. S20);
* ``scintillation_faraday``: co-pol leakage into HV from the Faraday-rotation spread inside the window (eq. S21).

Their level is ``CKL_LEVEL`` (1e-4) times the multiplier of the climatology's C_kL, so a level margin is the factor
(in dB) by which the irregularities may strengthen. Their output scalars
(``backscatter.error.<source>.*``, docs/output-format.md) give the screen and the azimuth-response statistics of the
case (median and 90th percentile over acquisitions and screen realisations, weak-scatter theory; with the Monte Carlo
of the azimuth compression beside it when the simulation mode includes it).
"""

from __future__ import annotations

import math

import numpy as np

from e2esim.error_terms.block_case import case_of
from e2esim.error_terms.modules import MAP_CELL_KEYS, ErrorTerm, source_param
from e2esim.errors import PhysicsInputError
from e2esim.module import fail
from e2esim.orbit.frames import EARTH_MEAN_RADIUS
from e2esim.params import Param
from e2esim.scintillation.acquisitions import ScreenSettings, acquisition_screens, mixture_quantiles
from e2esim.scintillation.cell import cell_acquisitions
from e2esim.scintillation.climatology import SOLAR_PRESETS
from e2esim.scintillation.effects import CKL_LEVEL, CalibratorFactor, DistributedTargetFactor, FaradayLeakage
from e2esim.scintillation.faraday_window import parallel_field, window_variance
from e2esim.scintillation.irf_monte_carlo import mixture_monte_carlo, peak_log_loss
from e2esim.scintillation.stacked import (
    stacked_halo_shares,
    stacked_mixture_quantiles,
    stacked_screens,
    stacked_weighted_sums,
)

SCREEN_PARAMS = (
    Param("solar", "str", "solar activity: 12-month sunspot number 10 (min) or 150 (max) (null: a map sweep's solar "
          "level, else max)", default=None, nullable=True, choices=tuple(SOLAR_PRESETS)),
    Param("sunspot_number", "float", "12-month sunspot number R instead of the preset of `solar` (null: the preset)",
          default=None, nullable=True, minimum=0.0, maximum=250.0),
    Param("percentile", "float", "percentile of the day-to-day spread of C_kL (50: the median screen)", default=50.0,
          unit="%", exclusive_minimum=0.0, exclusive_maximum=100.0, convert=False),
    Param("c_kl", "float", "height-integrated strength C_kL (SI, m^-(p + 3)) instead of the climatology (null: the "
          "climatology)", default=None, nullable=True, minimum=0.0),
    Param("spectral_index", "float", "phase spectral index p = 2 nu of the power law (Rino 1979), 1 < p < 5",
          default=2.67, exclusive_minimum=1.0, exclusive_maximum=5.0),
    Param("outer_scale_km", "float", "outer scale L_0 of the irregularities", default=10.0, unit="km",
          exclusive_minimum=0.0),
    Param("screen_height_km", "float", "height of the phase screen (below the orbit)", default=350.0, unit="km",
          exclusive_minimum=0.0),
    Param("drift_m_s", "float", "along-track drift of the irregularities", default=0.0, unit="m/s"),
    Param("azimuth_resolution_m", "float", "single-look azimuth (Rayleigh) resolution rho_a of the SAR", default=8.3,
          unit="m", exclusive_minimum=0.0),
    Param("lat_deg", "float", "latitude of a map cell, used when the chain has no geometry product (a map sweep "
          "sets it; null: the geometry's acquisitions)", default=None, nullable=True, unit="deg", minimum=-90.0,
          maximum=90.0, convert=False),
    Param("lon_deg", "float", "east longitude of that cell", default=None, nullable=True, unit="deg",
          minimum=-180.0, maximum=360.0, convert=False),
    Param("month", "int", "month of that cell's acquisitions (the 15th)", default=None, nullable=True, minimum=1,
          maximum=12),
    Param("pass", "str", "pass of that cell's acquisitions: dawn (06 h) or dusk (18 h) (null: a map sweep's pass, "
          "else dawn)", default=None, nullable=True, choices=("dawn", "dusk")),
)

SCREEN_SUMS = ("magnetic_latitude", "log10_ckl", "weak", "mean_irf_peak_loss_db")
"""The fields of ``AcquisitionScreens`` whose weighted sums over the acquisitions are output scalars
(``irf_outputs``)."""


class ScintillationTerm(ErrorTerm):
    """What the three terms share: the screen's settings, the acquisitions' screens and the IRF scalars."""

    needs: tuple = ()
    uses = ("geometry", "instrument")

    def screen_settings(self, case, memo: dict | None = None) -> ScreenSettings:
        """The case's screen settings; ``memo``: those already made for a block, by solar level and frequency."""
        si = self.si
        solar = si["solar"] or (getattr(case, "inputs", None) or {}).get(MAP_CELL_KEYS["solar"]) or "max"
        instrument = case.get("instrument")
        frequency = 435e6 if instrument is None else float(instrument.centre_frequency_hz)
        if memo is not None and (solar, frequency) in memo:
            return memo[solar, frequency]
        sunspots = SOLAR_PRESETS[solar] if si["sunspot_number"] is None else si["sunspot_number"]
        settings = ScreenSettings(sunspots, si["percentile"], si["spectral_index"], si["c_kl"], si["outer_scale_m"],
                                  si["screen_height_m"], si["drift_m_s"], frequency, si["azimuth_resolution_m"])
        if memo is not None:
            memo[solar, frequency] = settings
        return settings

    def acquisitions(self, case, memo: dict | None = None):
        """The case's ``geometry``, else the acquisitions of the cell the parameters name (``cell``); ``memo``:
        the cells' acquisitions already made for a block (a map's solar levels share them)."""
        geometry = case.get("geometry")
        if geometry is not None:
            return geometry
        cell = self.map_cell(case)
        if cell["lat"] is None or cell["lon"] is None or cell["month"] is None:
            raise fail(self, "the chain has no geometry product (no orbit section) and the term names no map cell",
                       "add an orbit section, or give lat_deg, lon_deg and month (a map sweep sets them)")
        key = (cell["lat"], cell["lon"], cell["month"], cell["pass"])
        if memo is None or key not in memo:
            acquisitions = cell_acquisitions(*key)
            if memo is None:
                return acquisitions
            memo[key] = acquisitions
        return memo[key]

    def map_cell(self, case) -> dict:
        """The cell of a chain without geometry: the term's lat_deg, lon_deg, month and pass where given, else the
        map sweep's cell (``MAP_CELL_KEYS``); a map's ascending pass is BIOMASS's dawn pass (ascending node at
        06 h), its descending pass the dusk pass."""
        si, inputs = self.si, getattr(case, "inputs", None) or {}
        cell = {name: si[key] if si[key] is not None else inputs.get(MAP_CELL_KEYS[name])
                for name, key in (("lat", "lat_deg"), ("lon", "lon_deg"), ("month", "month"), ("pass", "pass"))}
        cell["pass"] = {"ascending": "dawn", "descending": "dusk", None: "dawn"}.get(cell["pass"], cell["pass"])
        return cell

    def screen_site(self) -> tuple:
        """(lat, lon) (rad) of the irregularities when they are not over the acquisitions' pierce points."""
        return None, None

    def screens(self, case):
        try:
            return acquisition_screens(self.acquisitions(case), self.screen_settings(case), *self.screen_site())
        except PhysicsInputError as exc:
            raise fail(self, str(exc), None, key=exc.key) from exc

    def block_case_effects(self, block, model) -> list:
        """Every case's effect, with the screens and quantiles of the block's cases computed together
        (``stacked``: bit for bit those of each case alone)."""
        cases = [case_of(block, i) for i in range(len(block))]
        try:
            cells, settings = {}, {}
            screens = stacked_screens([self.acquisitions(c, cells) for c in cases],
                                      [self.screen_settings(c, settings) for c in cases], *self.screen_site())
        except PhysicsInputError as exc:
            raise fail(self, str(exc), None, key=exc.key) from exc
        quantiles = {p: stacked_mixture_quantiles(screens, p) for p in (0.5, 0.9)}
        sums = stacked_weighted_sums(screens, SCREEN_SUMS)
        extras = self.stacked_extras(screens)
        models = self.case_models(model)
        return [(self.effect(c, models[i], screens[i], {p: q[i] for p, q in quantiles.items()}, sums=sums[i],
                             **extras[i]),)
                for i, c in enumerate(cases)]

    def stacked_extras(self, screens: list) -> list:
        """Per case, further arguments of ``effect`` made for the block's cases together (``block_case_effects``)."""
        return [{} for _ in screens]

    def named(self, pairs) -> tuple:
        """``pairs`` as output scalars of this term: ``<source>.<name>`` (``Effect.outputs`` holds full keys)."""
        source = self.source
        return tuple((f"{source}.{name}", value) for name, value in pairs)

    def irf_outputs(self, case, screens, quantiles=None, sums=None) -> tuple:
        """(name, value) pairs: the screen and the response statistics of the case (module docstring);
        ``quantiles``: ``mixture_quantiles`` of ``screens`` by probability, ``sums``: the weighted sums of
        ``SCREEN_SUMS`` over the acquisitions, when already made (``block_case_effects``)."""
        w = screens.weight
        sums = sums or {name: np.sum(w * getattr(screens, name)) for name in SCREEN_SUMS}
        out = [("geomagnetic_latitude_deg", float(np.degrees(sums["magnetic_latitude"]))),
               ("log10_ckl_mean", float(sums["log10_ckl"])),
               ("weak_scatter_fraction", float(sums["weak"])),
               ("mean_irf_peak_loss_db", float(sums["mean_irf_peak_loss_db"]))]
        for tag, prob in (("median", 0.5), ("p90", 0.9)):
            q = mixture_quantiles(screens, prob) if quantiles is None else quantiles[prob]
            out += [(f"peak_loss_{tag}_db", q["peak_loss_db"]), (f"resolution_ratio_{tag}", q["resolution_ratio"]),
                    (f"shift_{tag}_m", q["shift_cells"] * self.si["azimuth_resolution_m"]),
                    (f"islr_{tag}_db", q["islr_db"])]
        if case.settings.montecarlo:
            mc = mixture_monte_carlo(case.rng, self.acquisitions(case), self.screen_settings(case), screens)
            out += [(f"mc_{name}", value) for name, value in mc.items()]
        return tuple(out)


class ScintillationSigma0(ScintillationTerm):
    """sigma0 of a distributed target through the screen (``DistributedTargetFactor``): energy that the shift and
    the halo move out of the product cell, replaced by the neighbours' in proportion to 1 - contrast."""

    type_name = "scintillation_sigma0"
    summary = "scintillation: sigma0 bias and spread of a distributed target (energy leaving the product cell)"
    params = (*SCREEN_PARAMS,
              Param("cell_length_m", "float", "azimuth length of the product cell (200 m: the BIOMASS AGB product)",
                    default=200.0, unit="m", exclusive_minimum=0.0),
              Param("contrast", "float", "1 - (sigma0 of the surroundings and ambiguity zones) / (sigma0 of the "
                    "cell): 0 a homogeneous forest, 1 dark surroundings (the upper bound)", default=1.0,
                    minimum=0.0, maximum=1.0),
              source_param("scintillation_sigma0"))

    effects_take_blocks = True
    effects_ignore_model = True

    def cell_cells(self) -> float:
        """The product cell's length in resolution cells, L_c / rho_a."""
        return self.si["cell_length_m"] / self.si["azimuth_resolution_m"]

    def stacked_extras(self, screens: list) -> list:
        return [{"halo_share": q} for q in stacked_halo_shares(screens, self.cell_cells())]

    def effect(self, case, model, screens=None, quantiles=None, halo_share=None, sums=None):
        screens = self.screens(case) if screens is None else screens
        halo_share = screens.halo_share(self.cell_cells()) if halo_share is None else halo_share
        return DistributedTargetFactor(
            self.source, CKL_LEVEL, "scintillation: energy moved out of the product cell (distributed target)",
            weight=tuple(screens.weight), shape=tuple(screens.shape), scale=tuple(screens.scale),
            shift_sd_cells=tuple(screens.shift_sd_cells),
            halo_share=tuple(halo_share),
            cell_fraction=self.si["azimuth_resolution_m"] / self.si["cell_length_m"], contrast=self.si["contrast"],
            outputs=self.named(self.irf_outputs(case, screens, quantiles, sums)))


class ScintillationCalibration(ScintillationTerm):
    """The gain error left by calibrating on the peak power of a point calibrator seen through the screen
    (``CalibratorFactor``), at the calibration site (default New Norcia, the BIOMASS transponder)."""

    type_name = "scintillation_calibration"
    summary = "scintillation: gain error from the peak loss of a point calibrator (transponder, corner reflector)"
    params = (*SCREEN_PARAMS,
              Param("site_lat_deg", "float", "geocentric latitude of the calibration site (New Norcia by default)",
                    default=-31.05, unit="deg", minimum=-90.0, maximum=90.0),
              Param("site_lon_deg", "float", "longitude of the calibration site (New Norcia by default)",
                    default=116.19, unit="deg", minimum=-360.0, maximum=360.0),
              Param("calibrations", "int", "number of calibrator acquisitions the gain is averaged over",
                    default=2, minimum=1),
              source_param("scintillation_calibration"))

    effects_take_blocks = True
    effects_ignore_model = True

    def screen_site(self) -> tuple:
        return self.si["site_lat_rad"], self.si["site_lon_rad"]

    def effect(self, case, model, screens=None, quantiles=None, sums=None):
        screens = self.screens(case) if screens is None else screens
        mean_z, second_z = peak_log_loss(case.rng, self.acquisitions(case), self.screen_settings(case), screens)
        mean_y = float(np.sum(screens.weight * mean_z))
        var_y = float(np.sum(screens.weight * second_z)) - mean_y * mean_y
        outputs = (("calibrator_peak_loss_mean_db", 10.0 / math.log(10.0) * mean_y),
                   *self.irf_outputs(case, screens, quantiles, sums))
        return CalibratorFactor(self.source, CKL_LEVEL, "scintillation: calibrator peak loss (gain error)",
                                mean_log=mean_y, var_log=max(var_y, 0.0) / self.si["calibrations"],
                                outputs=self.named(outputs))


class ScintillationFaraday(ScintillationTerm):
    """Co-polarised power leaking into HV from the spread of the Faraday rotation inside the estimation window
    (``FaradayLeakage``)."""

    type_name = "scintillation_faraday"
    summary = "scintillation: co-pol leakage into HV from the Faraday-rotation spread inside its window"
    needs = ("geometry", "scene.covariance")
    params = (*SCREEN_PARAMS,
              Param("window_km", "float", "side of the Faraday-rotation estimation window on the ground (Quegan "
                    "et al. 2018, Section 2: 2 km)", default=2.0, unit="km", exclusive_minimum=0.0),
              source_param("scintillation_faraday"))

    effects_take_blocks = True

    def effect(self, case, model, screens=None, quantiles=None, sums=None):  # sums: its outputs need none
        geometry = case["geometry"]
        settings = self.screen_settings(case)
        screens = self.screens(case) if screens is None else screens
        orbit_height = geometry.orbit.radius_m - EARTH_MEAN_RADIUS
        b_par = parallel_field(geometry, settings.height_m)
        s2 = window_variance(self.si["window_m"], b_par, settings.frequency_hz, 10.0 ** screens.log10_ckl,
                             settings.spectral_index, settings.outer_scale_m, settings.height_m, orbit_height,
                             screens.zenith)
        c = np.asarray(case["scene.covariance"].matrix)
        copol = float(np.real(c[0, 0] + c[2, 2] + 2.0 * c[0, 2]))
        channels = getattr(model, "channels", None) or (model.channel,)
        outputs = (("faraday_spread_rms_deg", float(np.degrees(np.sqrt(np.sum(screens.weight * s2))))),)
        return FaradayLeakage(self.source, CKL_LEVEL, "scintillation: Faraday-rotation spread inside the window",
                              scale=tuple(1.0 if ch == "hv" else 0.0 for ch in channels), looks=case.settings.looks,
                              weight=tuple(screens.weight), window_variance=tuple(s2), copol_power=copol,
                              outputs=self.named(outputs))


__all__ = ["ScintillationCalibration", "ScintillationFaraday", "ScintillationSigma0", "ScintillationTerm"]
