"""Ionosphere modules that compute Faraday rotation from the acquisition geometry (kind ``ionosphere``).

They read ``geometry`` (an orbit module's ``AcquisitionGeometry``) and the radar frequency from ``instrument``
and provide ``faraday.geophysical``, a ``FaradayClimatology`` (an ``EmpiricalFaraday`` with percentiles, TEC
and delays), and on request ``faraday.global_map``, the global maps of the climatology for the case's
orbit (``global_map_step_deg``):

* ``iri_climatology``: IRI electron density (PyIRI) along every line of sight, IGRF or dipole field;
* ``klobuchar_tec``: the Klobuchar broadcast model as a simple fallback (thin shell);
* ``user_tec``: a vertical TEC given by the user (thin shell).

All three add the day-to-day variability of the TEC about its median (``e2esim.ionosphere.variability``).
"""

from __future__ import annotations

from abc import abstractmethod

import numpy as np

from e2esim import products as P
from e2esim.errors import PhysicsInputError
from e2esim.faraday.climatology import climatology_from_integrals, site_path_integrals
from e2esim.faraday.global_climatology import global_climatology
from e2esim.geomag.field import FIELD_KINDS, FieldModel
from e2esim.geomag.igrf import IGRF_MODELS
from e2esim.ionosphere.iri import FOF2_MODELS
from e2esim.ionosphere.klobuchar import KLOBUCHAR_ALPHA_DEFAULT, KLOBUCHAR_BETA_DEFAULT, klobuchar_vtec
from e2esim.ionosphere.slant import METHODS, PathIntegrals, SlantSettings
from e2esim.ionosphere.variability import DEFAULT_TEC_VARIABILITY
from e2esim.module import Stage, fail
from e2esim.orbit.geometry import ray_points
from e2esim.params import Ordered, Param, ParamGroup, Requires

SOLAR_PRESETS = {"min": 70.0, "max": 180.0}
"""F10.7 (sfu) of the solar-activity presets: monthly F10.7 near the minima of cycles 23-25 is about 70 sfu
and near the maxima of cycles 23 and 25 about 180 sfu (NOAA SWPC observed solar cycle record)."""

_FIELD = ParamGroup("field", "geomagnetic field model", (
    Param("model", "str", "igrf, dipole (tilted centred dipole of IGRF) or aligned_dipole", default="igrf",
          choices=FIELD_KINDS),
    Param("epoch", "str", "date of the field coefficients (ISO; null: the middle of the acquisitions)", default=None,
          nullable=True),
    Param("coefficients", "str", "IGRF coefficient file", default="IGRF14", choices=IGRF_MODELS),
))

_COMMON = (
    Param("shell_height_km", "float", "thin-shell (pierce-point) height", default=350.0, unit="km", minimum=100.0,
          maximum=1500.0),
    Param("tec_variability", "float", "day-to-day coefficient of variation of TEC about the median (Rishbeth & "
          "Mendillo 2001)", default=DEFAULT_TEC_VARIABILITY, minimum=0.0, maximum=2.0),
    Param("variability_nodes", "int", "log-normal quantile nodes per acquisition", default=15, minimum=1, maximum=201),
    Param("global_map_step_deg", "float", "also provide global maps of the climatology for the case's orbit on a "
          "grid of this step (thin shell; for the report's faraday_climatology plot); null: none", default=None,
          unit="deg", exclusive_minimum=0.0, maximum=30.0, nullable=True, convert=False),
    _FIELD,
)


class _GeometryIonosphere(Stage):
    """Shared parts: field model, variability, the result object, the global maps."""

    kind = "ionosphere"
    needs = ("geometry", "instrument")
    provides = (P.FARADAY, P.FARADAY_MAP)  # every product it can provide; ``setup`` narrows it
    cache_setting = "off"  # no cache unless a subclass has a cache_dir parameter

    def setup(self):
        self.provides = (P.FARADAY,) + ((P.FARADAY_MAP,) if self.si["global_map_step_deg"] else ())
        self._maps: dict = {}  # global maps already made, by orbit and frequency

    def field_model(self, geometry) -> FieldModel:
        f = self.si["field"]
        epoch = f["epoch"]
        if epoch is None:
            t = geometry.time_utc.astype("int64")
            epoch = str(np.datetime64(int(t.mean()), "s").astype("datetime64[D]"))
        return FieldModel(f["model"], epoch, f["coefficients"])

    @abstractmethod
    def integrals(self, geometry, cache) -> PathIntegrals:
        """Path integrals (TEC, B.k-weighted TEC) of every acquisition's line of sight."""

    def case_integrals(self, case) -> PathIntegrals:
        """The path integrals of the case (``integrals`` of its geometry; a subclass whose TEC depends on more of the
        case overrides this)."""
        return self.integrals(case["geometry"], case.services.cache_for(self.cache_setting))

    def forward(self, case):
        geometry = case["geometry"]
        frequency = case["instrument"].centre_frequency_hz
        try:
            integrals = self.case_integrals(case)
            clim = climatology_from_integrals(
                integrals, 0, frequency, self.si["tec_variability"], self.si["variability_nodes"], geometry.weight,
                geometry.pass_label, geometry.site.name, label=f"{self.type_name} {geometry.site.name}",
            )
        except PhysicsInputError as exc:
            raise fail(self, str(exc)) from exc
        out = {"faraday.geophysical": clim}
        if self.si["global_map_step_deg"]:
            out["faraday.global_map"] = self.global_map(geometry.orbit, frequency, case.services)
        return out

    def global_map(self, orbit, frequency_hz: float, services):
        """Global maps of the climatology for ``orbit`` (thin shell at ``shell_height_km``), made once per orbit
        and frequency and kept with the module (cases of a sweep share it); the table itself is cached."""
        key = (orbit, frequency_hz)
        if key not in self._maps:
            settings = SlantSettings(method="thin_shell", shell_height_m=self.si["shell_height_m"])
            clim = global_climatology(orbit, self.si["global_map_step_deg"], settings=settings,
                                      cache=services.cache_for(self.cache_setting), progress=services.progress,
                                      executor=services.executor)
            self._maps[key] = clim.map(frequency_hz, self.si["tec_variability"])
        return self._maps[key]


class IRIClimatologyModule(_GeometryIonosphere):
    """Faraday rotation from the IRI (PyIRI) and IGRF along every line of sight of the acquisitions.

    Quegan et al. (2018), eq. (3) with Omega = A int N_e B.k ds / f^2; slant integration by thin shell,
    pierce-point profile or multi-layer ray tracing (e2esim.ionosphere.slant); IRI monthly medians
    interpolated to each date (or the monthly median itself) at the solar activity chosen; day-to-day
    variability log-normal about the median.
    """

    type_name = "iri_climatology"
    summary = "Faraday rotation from IRI electron density (PyIRI) and IGRF along each acquisition's line of sight"
    params = (
        Param("solar", "str", "solar activity: min (F10.7 70 sfu), max (180 sfu), or f107 (f107_sfu)", default="min",
              choices=("min", "max", "f107")),
        Param("f107_sfu", "float", "F10.7 when solar is f107", default=None, unit="sfu", minimum=50.0, maximum=400.0,
              nullable=True),
        Param("method", "str", "slant integration: thin_shell, pierce_profile or multilayer", default="multilayer",
              choices=METHODS),
        Param("bottom_height_km", "float", "lowest height integrated", default=60.0, unit="km", minimum=0.0,
              maximum=200.0),
        Param("layer_step_km", "float", "height step of the integration", default=10.0, unit="km",
              exclusive_minimum=0.0, maximum=100.0),
        Param("fof2_model", "str", "foF2 coefficient maps", default="ursi", choices=FOF2_MODELS),
        Param("monthly_medians", "bool", "use each month's median instead of interpolating between months to the day",
              default=False),
        *_COMMON,
        Param("cache_dir", "str", "HDF5 cache folder (null: $E2ESIM_CACHE or ~/.cache/e2esim; 'off': no cache)",
              default=None, nullable=True),
        Requires("f107_sfu", when="solar", equals="f107"),
        Ordered("bottom_height_km", "shell_height_km"),
    )

    def setup(self):
        super().setup()
        c = self.si
        self.f107 = c["f107_sfu"] if c["solar"] == "f107" else SOLAR_PRESETS[c["solar"]]

    @property
    def cache_setting(self):
        return self.si["cache_dir"]

    def integrals(self, geometry, cache) -> PathIntegrals:
        c = self.si
        settings = SlantSettings(method=c["method"], shell_height_m=c["shell_height_m"],
                                 bottom_height_m=c["bottom_height_m"], layer_step_m=c["layer_step_m"],
                                 field=self.field_model(geometry), fof2_model=c["fof2_model"],
                                 monthly_medians=c["monthly_medians"])
        return site_path_integrals(geometry, [self.f107], settings, cache)


class _ThinShellIonosphere(_GeometryIonosphere):
    """Thin-shell Faraday rotation from a vertical TEC at each acquisition's pierce point."""

    @abstractmethod
    def vertical_tec(self, geometry, lat, lon) -> np.ndarray:
        """Vertical TEC (electrons/m^2) at pierce points (lat, lon in rad) of ``geometry``'s acquisitions."""

    def integrals(self, geometry, cache, vertical_tec=None) -> PathIntegrals:
        """``vertical_tec`` : a function of (geometry, lat, lon) in place of the module's own (a value that depends
        on the case, handed in by the caller rather than kept on the module)."""
        h = self.si["shell_height_m"]
        ray = ray_points(geometry.target_ecef, geometry.satellite_ecef, np.array([h]))
        k = geometry.target_ecef - geometry.satellite_ecef
        k = k / np.linalg.norm(k, axis=-1, keepdims=True)
        bk = self.field_model(geometry).b_dot_k(ray.position[:, 0], k)
        vtec = (vertical_tec or self.vertical_tec)(geometry, ray.lat[:, 0], ray.lon[:, 0])
        stec = vtec / np.cos(ray.zenith[:, 0])
        return PathIntegrals(vtec[None], stec[None], (stec * bk)[None], bk, ray.zenith[:, 0], (float("nan"),),
                             "thin_shell")


class KlobucharModule(_ThinShellIonosphere):
    """The Klobuchar broadcast model (IS-GPS-200; Klobuchar 1987) at each pierce point, thin shell: the
    documented simple fallback (e2esim.ionosphere.klobuchar)."""

    type_name = "klobuchar_tec"
    summary = "Faraday rotation from the Klobuchar broadcast TEC model, thin shell (simple fallback)"
    params = (
        Param("alpha", "float", "Klobuchar alpha_0..3 (s/semicircle^n)", default=KLOBUCHAR_ALPHA_DEFAULT, length=4),
        Param("beta", "float", "Klobuchar beta_0..3 (s/semicircle^n)", default=KLOBUCHAR_BETA_DEFAULT, length=4),
        *_COMMON,
    )

    def vertical_tec(self, geometry, lat, lon):
        return klobuchar_vtec(lat, lon, geometry.ut_h, self.si["alpha"], self.si["beta"])


class UserTECModule(_ThinShellIonosphere):
    """A vertical TEC given by the user, mapped to each line of sight by the thin-shell model."""

    type_name = "user_tec"
    summary = "Faraday rotation from a user-given vertical TEC along each acquisition's line of sight (thin shell)"
    params = (
        Param("vtec_tecu", "float", "median vertical TEC", unit="TECU", minimum=0.0, maximum=1000.0),
        *_COMMON,
    )

    def vertical_tec(self, geometry, lat, lon):
        return np.full(np.shape(lat), self.si["vtec_el_m2"])
