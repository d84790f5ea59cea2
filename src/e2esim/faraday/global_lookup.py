"""Ionosphere module ``global_climatology``: the Faraday rotation of one map cell, month, pass and solar level,
looked up in the global climatology table (kind ``ionosphere``; the stage of map sweeps, docs/user-guide.md).

The table is computed once per orbit, month, solar level and settings (``e2esim.faraday.cell_lookup``) and kept
in memory and in the array cache; a case only looks its cell up. The cell's acquisitions are the swath positions
of its pass on the 15th of the month at the pass's local time, with the IRI monthly median electron density
(PyIRI; Bilitza et al. 2022) and the IGRF field along each line of sight: Omega = A int N_e B.k ds / f^2
(Quegan et al. 2018, eq. 3; thin shell by default, e2esim.ionosphere.slant). The day-to-day variability of TEC
about the median multiplies each by log-normal factors (Rishbeth & Mendillo 2001; e2esim.ionosphere.variability).
The product is the ``FaradayClimatology`` of those samples, as the site climatologies give (mean and SD equal
``GlobalClimatology.statistics`` of the month at the cell).
"""

from __future__ import annotations

import numpy as np

from e2esim import products as P
from e2esim.block import Values
from e2esim.errors import ConfigError, PhysicsInputError
from e2esim.faraday.cell_lookup import cell_integrals, month_table
from e2esim.faraday.climatology import FaradayClimatology, MapCells
from e2esim.faraday.climatology_modules import SOLAR_PRESETS
from e2esim.geomag.field import FIELD_KINDS, FieldModel
from e2esim.geomag.igrf import IGRF_MODELS
from e2esim.ionosphere.slant import METHODS, SlantSettings
from e2esim.ionosphere.variability import DEFAULT_TEC_VARIABILITY
from e2esim.module import Stage, fail
from e2esim.orbit.acquisition import swath_incidences
from e2esim.orbit.geometry import view_geometry
from e2esim.orbit.sunsync import PASSES, SunSynchronousOrbit
from e2esim.params import Ordered, Param, ParamGroup, Requires, to_si, validate_section

PASS_NAMES = ("dawn", "dusk", "ascending", "descending")

_ORBIT = ParamGroup("orbit", "the orbit whose passes see the cell (defaults: ESA BIOMASS, 666 km dawn-dusk, "
                    "ascending node 06:00, left-looking, incidence 23-33.75 deg; CEOS EO Handbook, "
                    "Quegan et al. 2018)", (
    Param("altitude_km", "float", "orbit altitude", default=666.0, unit="km", minimum=150.0, maximum=6000.0),
    Param("ltan_hours", "float", "local mean solar time of the ascending node", default=6.0, unit="h", minimum=0.0,
          exclusive_maximum=24.0),
    Param("look_side", "str", "side the radar looks to", default="left", choices=("left", "right")),
    Param("incidence_near_deg", "float", "incidence angle at near range", default=23.0, unit="deg",
          exclusive_minimum=0.0, exclusive_maximum=90.0),
    Param("incidence_far_deg", "float", "incidence angle at far range", default=33.75, unit="deg",
          exclusive_minimum=0.0, exclusive_maximum=90.0),
    Param("swath_samples", "int", "positions across the swath (equal ground-range intervals)", default=3, minimum=1,
          maximum=101),
    Param("earth_rotation", "bool", "include the Earth's rotation in heading and zero-Doppler geometry", default=True),
))

_FIELD = ParamGroup("field", "geomagnetic field model", (
    Param("model", "str", "igrf, dipole (tilted centred dipole of IGRF) or aligned_dipole", default="igrf",
          choices=FIELD_KINDS),
    Param("epoch", "str", "date of the field coefficients (ISO)", default="2026-01-01"),
    Param("coefficients", "str", "IGRF coefficient file", default="IGRF14", choices=IGRF_MODELS),
))


class GlobalClimatologyLookup(Stage):
    """Faraday rotation of a map cell from the global IRI/IGRF climatology table: one table per month, solar
    level and settings for all cases, each case a look-up (module docstring)."""

    kind = "ionosphere"
    type_name = "global_climatology"
    summary = ("Faraday rotation of a lat/lon cell, month, pass and solar level looked up in the global IRI/IGRF "
               "climatology table (map sweeps)")
    needs = ("instrument",)
    provides = (P.FARADAY,)
    params = (
        Param("lat_deg", "float", "latitude of the cell centre (a map sweep sets it)", unit="deg", minimum=-90.0,
              maximum=90.0, convert=False),
        Param("lon_deg", "float", "east longitude of the cell centre (a map sweep sets it)", unit="deg",
              minimum=-180.0, maximum=360.0, convert=False),
        Param("month", "int", "month of the year (the IRI median of the 15th)", minimum=1, maximum=12),
        Param("pass", "str", "the pass: dawn or dusk (by its equator crossing), or ascending or descending",
              default="dawn", choices=PASS_NAMES),
        Param("solar", "str", "solar activity: min (F10.7 70 sfu), max (180 sfu), or f107 (f107_sfu)", default="min",
              choices=("min", "max", "f107")),
        Param("f107_sfu", "float", "F10.7 when solar is f107", default=None, unit="sfu", minimum=50.0, maximum=400.0,
              nullable=True),
        Param("year", "int", "year of the dates (the 15th of each month)", default=2026, minimum=1960, maximum=2100),
        Param("grid_step_deg", "float", "cell size of the climatology table (set it to the map sweep's step, so "
              "that each cell is a table cell)", default=1.0, unit="deg", exclusive_minimum=0.0, maximum=30.0,
              convert=False),
        Param("table_lat_range_deg", "float", "latitudes the table covers (the map's region is enough)",
              default=(-90.0, 90.0), unit="deg", length=2, minimum=-90.0, maximum=90.0, convert=False),
        Param("table_lon_range_deg", "float", "longitudes the table covers", default=(-180.0, 180.0), unit="deg",
              length=2, minimum=-180.0, maximum=360.0, convert=False),
        Param("method", "str", "slant integration: thin_shell, pierce_profile or multilayer", default="thin_shell",
              choices=METHODS),
        Param("shell_height_km", "float", "thin-shell (pierce-point) height", default=350.0, unit="km",
              minimum=100.0, maximum=1500.0),
        Param("bottom_height_km", "float", "lowest height integrated (multilayer, pierce_profile)", default=60.0,
              unit="km", minimum=0.0, maximum=200.0),
        Param("layer_step_km", "float", "height step of the integration (multilayer, pierce_profile)", default=10.0,
              unit="km", exclusive_minimum=0.0, maximum=100.0),
        Param("tec_variability", "float", "day-to-day coefficient of variation of TEC about the median (Rishbeth & "
              "Mendillo 2001)", default=DEFAULT_TEC_VARIABILITY, minimum=0.0, maximum=2.0),
        Param("variability_nodes", "int", "log-normal quantile nodes per acquisition", default=15, minimum=1,
              maximum=201),
        _ORBIT,
        _FIELD,
        Param("cache_dir", "str", "HDF5 cache folder of the table (null: $E2ESIM_CACHE or ~/.cache/e2esim; 'off': "
              "no cache)", default=None, nullable=True),
        Requires("f107_sfu", when="solar", equals="f107"),
        Ordered("table_lat_range_deg"),
        Ordered("table_lon_range_deg"),
        Ordered("bottom_height_km", "shell_height_km"),
    )

    case_params = ("lat_deg", "lon_deg", "month", "pass", "solar")  # a map sweep's cells, months and passes

    @classmethod
    def map_latitudes_seen(cls, section, lat_deg, passes: tuple, where):
        """{pass: bool (n_lat,)}: the latitudes each pass of this section's orbit sees at some swath position
        (``visible_latitudes``)."""
        orbit = orbit_settings(section.get("orbit"), where)
        try:
            return {p: visible_latitudes(orbit, lat_deg, p) for p in passes}
        except PhysicsInputError as exc:  # an orbit without such a pass, impossible incidences
            raise ConfigError(where.child("orbit"), str(exc)) from exc

    def setup(self):
        c = self.si
        o = c["orbit"]
        if not o["incidence_near_rad"] < o["incidence_far_rad"]:
            raise PhysicsInputError("the near-range incidence must be below the far-range incidence",
                                    key="orbit.incidence_near_deg")
        self.orbit, self.incidence_deg = _orbit_and_swath(o["altitude_m"], o["ltan_hours"], o["look_side"],
                                                          o["earth_rotation"], o["incidence_near_rad"],
                                                          o["incidence_far_rad"], o["swath_samples"])
        self.pass_name, self.pass_label, self.f107 = self.when(c["pass"], c["solar"])
        f = c["field"]
        self.settings = _slant_settings(c["method"], c["shell_height_m"], c["bottom_height_m"], c["layer_step_m"],
                                        f["model"], f["epoch"], f["coefficients"])

    def when(self, pass_name: str, solar: str) -> tuple:
        """(the pass's name in ``PASSES``, its label, F10.7 (sfu)) of a pass (dawn, dusk, ascending,
        descending) and a solar level (min, max, f107). Raises ``PhysicsInputError``."""
        name = pass_name if pass_name in PASSES else self.orbit.pass_for_label(pass_name)
        f107 = self.si["f107_sfu"] if solar == "f107" else SOLAR_PRESETS[solar]
        if f107 is None:
            raise PhysicsInputError("solar level f107 needs f107_sfu", key="f107_sfu")
        return name, self.orbit.pass_label(name), f107

    def table(self, services, month: int | None = None, f107: float | None = None):
        """The climatology table of a month and solar level (F10.7, sfu), shared by every case of them
        (default: the configured ones)."""
        c = self.si
        return month_table(self.orbit, c["grid_step_deg"], c["month"] if month is None else month,
                           self.f107 if f107 is None else f107, self.incidence_deg, self.settings,
                           c["table_lat_range_deg"], c["table_lon_range_deg"], cache=services.cache_for(c["cache_dir"]),
                           executor=services.executor, progress=services.progress, memo=services.memo)

    forward_takes_blocks = True

    def forward(self, case):
        """The climatology of a case's cell, month, pass and solar level; of a block of cases at once (each month,
        pass and solar level's table read for all of its cells in one look-up: a ``FaradayClimatology`` with a case
        axis, whose ``item`` is a case's)."""
        c, v = self.si, self.block_values(case)
        n = len(case)
        arrays = {name: np.full((n, len(self.incidence_deg)), np.nan) for name in ("faraday", "stec", "vtec")}
        f107, labels = np.empty(n), np.empty(n, dtype=object)
        when = Values.of(list(zip(v["month"].tolist(), v["pass"].tolist(), v["solar"].tolist())))
        for code, (month, pass_given, solar) in enumerate(when.values):
            rows = np.flatnonzero(when.index == code)
            try:
                pass_name, labels[rows], f107[rows] = self.when(pass_given, solar)
                found = cell_integrals(self.table(case.services, month, f107[rows[0]]), PASSES.index(pass_name),
                                       v["lat_deg"][rows].astype(float), v["lon_deg"][rows].astype(float))
            except PhysicsInputError as exc:
                raise fail(self, str(exc), key=exc.key) from exc
            for name, values in arrays.items():
                values[rows] = found[name]
        self._check_seen(arrays["faraday"], v["lat_deg"], labels)
        frequency = case.column("instrument", "centre frequency", lambda instrument: instrument.centre_frequency_hz)
        cells = MapCells(v["lat_deg"].astype(float), v["lon_deg"].astype(float), v["month"].astype(int))
        return {"faraday.geophysical": case.product_of(FaradayClimatology.of_cells(
            arrays["faraday"], arrays["stec"], arrays["vtec"], np.broadcast_to(np.asarray(frequency, float), (n,)),
            f107, labels, cells, c["tec_variability"], c["variability_nodes"], c["method"]))}

    def _check_seen(self, faraday, lat_deg, pass_label) -> None:
        """Refuse a case whose pass sees its cell at no swath position (faraday: (cases, positions), NaN where
        not seen)."""
        blind = np.flatnonzero(~np.any(np.isfinite(faraday), axis=-1))
        if blind.size:
            k = blind[0]
            raise fail(self, f"the {pass_label[k]} pass of this orbit cannot see latitude {float(lat_deg[k]):g} deg "
                       "at any swath position", "restrict the map's latitudes (sweep.map.lat_range_deg)",
                       key="lat_deg")


def _orbit_and_swath(altitude_m, ltan_hours, look_side, earth_rotation, near_rad, far_rad, samples) -> tuple:
    """The orbit and its swath positions (incidence, deg). Made where asked (some 30 us): a map's cells share one
    module, set up once, and the month tables are found by the orbit's value (``cell_lookup.month_table``)."""
    orbit = SunSynchronousOrbit(altitude_m, ltan_hours, look_side, earth_rotation)
    return orbit, tuple(float(x) for x in np.degrees(swath_incidences(orbit, near_rad, far_rad, samples)))


def _slant_settings(method, shell_height_m, bottom_height_m, layer_step_m, field_kind, epoch, coefficients):
    """The slant-integration settings (a few us to make; found by value, as the orbit)."""
    return SlantSettings(method=method, shell_height_m=shell_height_m, bottom_height_m=bottom_height_m,
                         layer_step_m=layer_step_m, field=FieldModel(field_kind, epoch, coefficients))


def visible_latitudes(orbit_config: dict, lat_deg, pass_name: str) -> np.ndarray:
    """True where ``pass_name`` (dawn, dusk, ascending, descending) of the orbit of a ``global_climatology``
    section's ``orbit`` group (its SI values) sees latitude ``lat_deg`` (deg) at some swath position."""
    o = orbit_config
    orbit, incidence_deg = _orbit_and_swath(o["altitude_m"], o["ltan_hours"], o["look_side"], o["earth_rotation"],
                                            o["incidence_near_rad"], o["incidence_far_rad"], o["swath_samples"])
    name = pass_name if pass_name in PASSES else orbit.pass_for_label(pass_name)
    view = view_geometry(orbit, np.radians(np.asarray(lat_deg, float))[None, :], 0.0,
                         np.radians(np.asarray(incidence_deg))[:, None], name)
    return np.any(view.valid, axis=0)


def orbit_settings(section, where) -> dict:
    """The SI values of a ``global_climatology`` section's ``orbit`` group (``section``: its raw mapping or None;
    the defaults where absent), validated as the module validates them; ``where``: the section's location."""
    return to_si((_ORBIT,), validate_section((_ORBIT,), {"orbit": section or {}}, where))["orbit"]
