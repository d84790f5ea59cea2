"""Calibration sites: where they are, what they are, what they can calibrate and how well (issue 25, item 1).

Presets for the sites Quegan et al. (2018), Section 4, names. Every value carries its source, or is stated as an
assumption with the range it may take (``Assumed``): the paper itself says the P-band backscatter of the
desert and the ice sheet will first be measured during the commissioning phase. The Amazon is deliberately not
a preset: BIOMASS measures its change, so it cannot be a stable reference (Quegan et al. 2018, Section 4).

Conventions: positions are geocentric latitude and longitude (rad) on the spherical Earth; sigma0 and RCS are
linear (m^2/m^2, m^2) inside, dB only in YAML keys; ``stability`` is the relative standard deviation of the
site's response from one visit to the next (a fraction of its power).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from e2esim.errors import PhysicsInputError

SITE_TYPES = ("transponder", "corner_reflector", "distributed", "point_scatterers")
PARAMETERS = ("gain", "crosstalk", "imbalance")
"""The system parameters a campaign tracks: absolute gain |A|^2 (dB), crosstalk delta and channel imbalance f
(complex, Quegan et al. 2018, eq. 11; Men et al. 2021, eq. 1)."""


@dataclass(frozen=True)
class CalibrationSite:
    """One calibration site.

    name : label. lat, lon : geocentric latitude and longitude (rad). type : one of ``SITE_TYPES``.
    calibrates : the parameters its visits measure (subset of ``PARAMETERS``).
    snr_db : signal-to-noise (point targets: peak power to noise; distributed: co-polarised sigma0 over NESZ) (dB).
    scr_db : signal-to-clutter of a point target (dB); inf for a distributed target.
    looks : independent looks averaged per visit (a distributed target's area over its resolution cell; the
        number of scatterers for point scatterers).
    stability : relative SD of the site's response between visits (fraction of power).
    incidence_slope_db_per_deg : how sigma0 or RCS changes with incidence (dB/deg), corrected by the model of the
        site; its uncertainty is inside ``stability``.
    sources : what each value rests on (text, one entry per value or assumption).
    """

    name: str
    lat: float
    lon: float
    type: str
    calibrates: tuple
    snr_db: float
    scr_db: float = math.inf
    looks: float = 1.0
    stability: float = 0.0
    incidence_slope_db_per_deg: float = 0.0
    sources: tuple = field(default=(), compare=False)

    def __post_init__(self):
        if not -math.pi / 2 <= self.lat <= math.pi / 2:
            raise PhysicsInputError(f"site {self.name}: latitude {math.degrees(self.lat):g} deg is outside "
                                    f"[-90, 90]", key="lat_deg")
        if self.type not in SITE_TYPES:
            raise PhysicsInputError(f"site {self.name}: type {self.type!r} is not one of {', '.join(SITE_TYPES)}",
                                    key="type")
        bad = [p for p in self.calibrates if p not in PARAMETERS]
        if bad or not self.calibrates:
            raise PhysicsInputError(f"site {self.name}: calibrates {list(self.calibrates)!r}; allowed: one or more "
                                    f"of {', '.join(PARAMETERS)}", key="calibrates")
        if not self.looks >= 1:
            raise PhysicsInputError(f"site {self.name}: looks {self.looks!r} must be >= 1", key="looks")
        if not self.stability >= 0:
            raise PhysicsInputError(f"site {self.name}: stability {self.stability!r} must be >= 0",
                                    key="stability_percent")

    @property
    def snr(self) -> float:
        return 10 ** (self.snr_db / 10)

    @property
    def scr(self) -> float:
        return 10 ** (self.scr_db / 10)


def _site(name, lat_deg, lon_deg, **kw) -> CalibrationSite:
    return CalibrationSite(name, math.radians(lat_deg), math.radians(lon_deg), **kw)


PRESETS = {
    # ESA's BIOMASS calibration transponder (BCT) at New Norcia, Australia (ESA releases 2025; mission facts).
    # A 5 m active polarimetric calibrator: all four responses, so gain, crosstalk and imbalance (Quegan et al.
    # 2018, Section 5.1). SNR and SCR assumed: 40 dB (range 30-50 dB) for an active calibrator, 30 dB SCR
    # (range 25-40 dB) over the station's low vegetation.
    "new_norcia_transponder": _site(
        "new_norcia_transponder", -31.048, 116.192, type="transponder", calibrates=PARAMETERS, snr_db=40.0,
        scr_db=30.0, stability=0.01,
        sources=("position: ESA New Norcia station (31.048 S, 116.192 E)",
                 "calibrates gain, crosstalk, imbalance: Quegan et al. 2018, Section 5.1",
                 "assumed: SNR 40 dB (30-50), SCR 30 dB (25-40), stability 1 % (0.5-3 %)")),
    # Selima Sand Sheet, eastern Sahara (Quegan et al. 2018, Section 4): co-polarised sigma0 about -23 dB against
    # the -27 dB NESZ, so 4 dB SNR; the cross-polarised return is much weaker, so it calibrates the gain and the
    # HH/VV imbalance (a bare desert is assumed reflection-symmetric with equal co-polarised powers) only.
    "selima_sand_sheet": _site(
        "selima_sand_sheet", 21.5, 29.3, type="distributed", calibrates=("gain", "imbalance"), snr_db=4.0,
        looks=1000.0, stability=0.05, incidence_slope_db_per_deg=-0.1,
        sources=("sigma0 about -23 dB co-pol vs NESZ -27 dB: Quegan et al. 2018, Section 4",
                 "position: centre of the sheet, about 21.5 N 29.3 E (assumed, the sheet spans about 1 deg)",
                 "assumed: 1000 independent looks per visit (500-5000), stability 5 % (2-10 %), "
                 "incidence slope -0.1 dB/deg (-0.3-0)")),
    # Dome-C, Antarctica (Quegan et al. 2018, Section 4): bright and stable at L-band (Aquarius, 29 deg); P-band
    # level unknown before commissioning. Calibrates the gain and HH/VV imbalance.
    "dome_c": _site(
        "dome_c", -75.1, 123.35, type="distributed", calibrates=("gain", "imbalance"), snr_db=8.0, looks=5000.0,
        stability=0.02, incidence_slope_db_per_deg=-0.15,
        sources=("stable ice sheet, Aquarius L-band bright and stable: Quegan et al. 2018, Section 4",
                 "position: Concordia station 75.1 S 123.35 E",
                 "assumed: SNR 8 dB (0-15), 5000 looks (1000-20000), stability 2 % (1-5 %), "
                 "incidence slope -0.15 dB/deg (-0.3-0)")),
    # Permanent point scatterers (Quegan et al. 2018, Section 4): desert with isolated rocks, savanna with isolated
    # trees, urban areas; far fewer in the cross-polarised channels, so they calibrate the gain only.
    "sahel_point_scatterers": _site(
        "sahel_point_scatterers", 13.5, 2.1, type="point_scatterers", calibrates=("gain",), snr_db=25.0,
        scr_db=15.0, looks=10.0, stability=0.05,
        sources=("types of PPS, fewer in cross-pol: Quegan et al. 2018, Section 4",
                 "assumed: a savanna with isolated trees near 13.5 N 2.1 E, 10 scatterers (3-30), SNR 25 dB "
                 "(15-35), SCR 15 dB (10-25), stability 5 % (2-10 %)")),
}


SITE_KEYS = {"name": str, "lat_deg": float, "lon_deg": float, "type": str, "calibrates": list, "snr_db": float,
             "scr_db": float, "looks": float, "stability_percent": float, "incidence_slope_db_per_deg": float,
             "sources": list}
REQUIRED_KEYS = ("name", "lat_deg", "lon_deg", "type", "calibrates", "snr_db")


def site_from_mapping(entry: dict, where: str) -> CalibrationSite:
    """A ``CalibrationSite`` from a user's YAML mapping (degrees and dB at the edge). ``where`` is the key path of
    the entry; a bad value raises ``PhysicsInputError`` whose ``key`` is ``where.<key>``."""
    if not isinstance(entry, dict):
        raise PhysicsInputError(f"{entry!r} is not a mapping of site keys ({', '.join(SITE_KEYS)})", key=where)
    for k in entry:
        if k not in SITE_KEYS:
            raise PhysicsInputError(f"unknown site key {k!r}; allowed: {', '.join(SITE_KEYS)}", key=f"{where}.{k}")
    for k in REQUIRED_KEYS:
        if k not in entry:
            raise PhysicsInputError(f"the site needs {k!r}", key=f"{where}.{k}")
    values = {}
    for k, v in entry.items():
        want = SITE_KEYS[k]
        ok = isinstance(v, want) if want is not float else (isinstance(v, (int, float)) and not isinstance(v, bool))
        if not ok or (want is float and not math.isfinite(v) and k != "scr_db"):
            raise PhysicsInputError(f"{v!r} is not {'a number' if want is float else 'a ' + want.__name__}",
                                    key=f"{where}.{k}")
        values[k] = v
    try:
        return CalibrationSite(
            str(values["name"]), math.radians(values["lat_deg"]),
            math.radians(((values["lon_deg"] + 180.0) % 360.0) - 180.0), values["type"],
            tuple(values["calibrates"]), float(values["snr_db"]), float(values.get("scr_db", math.inf)),
            float(values.get("looks", 1.0)), float(values.get("stability_percent", 0.0)) / 100.0,
            float(values.get("incidence_slope_db_per_deg", 0.0)), tuple(str(s) for s in values.get("sources", ())))
    except PhysicsInputError as exc:
        raise PhysicsInputError(str(exc), key=f"{where}.{exc.key}" if exc.key else where) from exc


def preset(name: str) -> CalibrationSite:
    if name not in PRESETS:
        raise PhysicsInputError(f"no preset site {name!r}; presets: {', '.join(PRESETS)}")
    return PRESETS[name]
