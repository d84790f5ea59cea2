"""The named, typed products stages exchange, declared once with their type, units and output scalars.

A stage declares the products it ``needs`` (names) and ``provides`` (these declarations); the runner
orders the chain by them, checks that every product a stage needs is provided by an earlier stage
(``e2esim validate`` says which module needs it and which modules could provide it), and checks the type
of every product a stage returns. A plug-in declares its own products the same way, in its own package:

    STACK = Product("scene.stack", "my_package.stack:StackCovariance", "3N x 3N covariance of N passes")

Numbers inside a product are SI (radians, m^2/m^2, Hz, m), may carry a leading case axis (a block of sweep
cases), and every product type that writes output scalars has a ``scalars()`` method; ``scalars`` here
is the prefix of their names in summary.json and results.h5 (None: not written; "": names as they are), and
``units`` the units of those whose name does not end in its unit (``_db``, ``_percent``, ...): an output scalar
takes its unit from the product that made it (``e2esim.io.scalar_units``), a plug-in's as well.
"""

from __future__ import annotations

import functools
import importlib
import re
from dataclasses import dataclass

from e2esim.budget.result import BackscatterBudget
from e2esim.calibration.record import CalibrationRecord
from e2esim.error_model import ErrorModel
from e2esim.faraday.distribution import FaradayDistribution
from e2esim.faraday.global_climatology import FaradayMap
from e2esim.instrument.description import InstrumentDescription
from e2esim.instrument.system_errors import SystemErrorModel
from e2esim.orbit.acquisition import AcquisitionGeometry
from e2esim.requirements.verdict import RequirementVerdicts
from e2esim.retrieval.agb_error import AGBError
from e2esim.scene.covariance import ScatteringCovariance
from e2esim.stack.scene import StackScene
from e2esim.units import COUNT, DIMENSIONLESS, SIGMA, SIGMA_SQUARED


@dataclass(frozen=True)
class Product:
    """Declaration of one product.

    name : dotted name, e.g. "faraday.geophysical". type : the class of its value (or "module:Class", imported
    when first checked, for a plug-in that keeps its declarations free of imports). description : what it is,
    units and shape.
    scalars : prefix of its output scalars (the value's ``scalars()``), "" for none, None if not written.
    units : ((pattern, unit), ...): the unit of its output scalars whose name (after the prefix) the regular
        expression ``pattern`` matches whole; a name no pattern matches carries its unit at its end (``_db``,
        ``_deg``, ``_percent``, ...; e2esim.io.scalar_units) or has the unit "unknown".
    """

    name: str
    type: object
    description: str
    scalars: str | None = None
    units: tuple = ()

    def __post_init__(self):
        if not isinstance(self.units, tuple) or not all(
                isinstance(u, tuple) and len(u) == 2 and all(isinstance(x, str) for x in u) for u in self.units):
            raise ValueError(f"product {self.name!r}: units must be a tuple of (pattern, unit) text pairs, e.g. "
                             f"((\"s4\", \"1\"),), not {self.units!r}")
        for pattern, _ in self.units:
            try:
                re.compile(pattern)
            except re.error as exc:
                raise ValueError(f"product {self.name!r}: units pattern {pattern!r} is not a regular expression: "
                                 f"{exc}") from None

    def unit_of(self, name: str) -> str | None:
        """The unit this product declares for its output scalar ``name`` (prefix included), or None."""
        prefix = f"{self.scalars}." if self.scalars else ""
        if self.scalars is None or not name.startswith(prefix):
            return None
        rest = name[len(prefix):]
        return next((unit for pattern, unit in self.units if re.fullmatch(pattern, rest)), None)

    def check(self, value, by: str) -> None:
        """Raise TypeError unless ``value`` is of the declared type (``by`` names the stage)."""
        cls = _resolve(self.type) if isinstance(self.type, str) else self.type
        if not isinstance(value, cls):
            raise TypeError(f"{by} returned a {type(value).__name__} for product {self.name!r}, which must be a "
                            f"{getattr(cls, '__name__', cls)}")


@functools.cache
def _resolve(path: str):
    module, _, name = path.partition(":")
    return getattr(importlib.import_module(module), name)


GEOMETRY = Product(
    "geometry", AcquisitionGeometry,
    "every acquisition of the site: time (UTC), pass, incidence (rad), heading, look vector, satellite and target "
    "positions (ECEF, m), ionospheric pierce point, weights; arrays over acquisitions")
SCENE = Product(
    "scene.covariance", ScatteringCovariance,
    "3x3 covariance of (S_hh, S_hv, S_vv) in backscattering-coefficient units (m^2/m^2), with AGB (t/ha) and "
    "biome", scalars="scene",
    units=((r"sigma_hh|sigma_hv|sigma_vv|hhvv_magnitude", SIGMA), (r"agb_t_ha", "t/ha")))
STACK_SCENE = Product(
    "scene.stack", StackScene,
    "a forest seen by an acquisition stack of N passes: times (s), vertical wavenumbers (rad/m), incidences (rad), "
    "the random-volume-over-ground structure, temporal decorrelation and the 3N x 3N covariance (m^2/m^2)",
    scalars="stack")
INSTRUMENT = Product(
    "instrument", InstrumentDescription,
    "how the instrument states its specification: crosstalk and channel-imbalance levels (dB, with their "
    "convention), NESZ (dB), centre frequency and bandwidth (Hz)", scalars="instrument")
SYSTEM = Product(
    "system", SystemErrorModel,
    "the instrument's system errors before calibration: variances and pair correlations of crosstalk and "
    "channel imbalance (Men et al. 2021, Section III), noise power (m^2/m^2), gain error (dB)")
FARADAY = Product(
    "faraday.geophysical", FaradayDistribution,
    "distribution of the one-way Faraday rotation Omega (rad) the case sees before any correction",
    scalars="faraday", units=((r"tec_variability", DIMENSIONLESS),))
FARADAY_MAP = Product(
    "faraday.global_map", FaradayMap,
    "global maps of the Faraday-rotation climatology for the case's orbit and frequency: mean, SD and mean |Omega| "
    "(deg) per pass, solar level, latitude and longitude, and their zonal means")
CALIBRATION = Product(
    "calibration", CalibrationRecord,
    "the calibration strategy applied (its steps) and their results: the errors of what each step estimated, "
    "with their theory, and the residual model's fields", scalars="calibration",
    units=((r"steps", COUNT), (r".*chi2_mean", DIMENSIONLESS),
           (r"residual\.(max_abs_correlation_outside_pairs|max_crosstalk_noncircularity)", DIMENSIONLESS)))
SYSTEM_RESIDUAL = Product(
    "system.residual", SystemErrorModel,
    "the system errors the propagation applies after calibration (the raw ones when nothing corrects them); "
    "with faraday.residual it describes the corrected data (e2esim.calibration.record)", scalars="system",
    units=((r"crosstalk_variance|imbalance_variance", DIMENSIONLESS), (r"noise_power", SIGMA), (r".*gain.*", "dB")))
FARADAY_RESIDUAL = Product(
    "faraday.residual", FaradayDistribution,
    "the Faraday rotation (rad) the propagation applies together with system.residual (none once a "
    "polarimetric step has absorbed it into the residual crosstalk)", scalars="faraday_residual",
    units=((r"tec_variability", DIMENSIONLESS),))
BACKSCATTER_ERROR = Product(
    "backscatter.error", ErrorModel,
    "error model of the backscatter estimate (e2esim.error_model.ErrorModel): moments at any error level, "
    "with a source removed, contributions; Monte Carlo samples when simulated", scalars="",
    units=((r"analytic\.(mean|sd|bias_\w+)", SIGMA), (r"analytic\.(variance|var_\w+)", SIGMA_SQUARED),
           (r"montecarlo\.(mean|sd|mean_se)", SIGMA), (r"montecarlo\.(variance|variance_se)", SIGMA_SQUARED),
           (r"montecarlo\.(samples|realisations)", COUNT),
           (r"montecarlo\.(skewness|excess_kurtosis|ks_distance)", DIMENSIONLESS), (r"comparison\.\w+", DIMENSIONLESS),
           (r"error_term\.\w+\.(band_fraction|time_fraction|energy_ratio|looks_factor|resolution_ratio)",
            DIMENSIONLESS)))
BACKSCATTER_BUDGET = Product(
    "backscatter.budget", BackscatterBudget,
    "random-error budget of sigma0 at the product scale (Ahmed et al. 2014): relative SDs of speckle and noise, "
    "temporal, calibration and area projection per channel", scalars="budget", units=((r"looks", COUNT),))
AGB_ERROR = Product(
    "agb.error", AGBError,
    "relative AGB error (AGB_hat / AGB - 1): analytic mean and SD of the sigma error, Monte Carlo samples, the "
    "named contributions", scalars="agb",
    units=((r"exponent", DIMENSIONLESS), (r"contribution\.\w+\.campaigns(_failed)?", COUNT)))
VERDICTS = Product(
    "verdicts", RequirementVerdicts,
    "the verdict of every requirement, in scenario order: pass/fail, value, limit, margin, details, trade-off "
    "curves, dominant contributor", scalars="",
    units=((r"requirement\d+\.passed", "1 (pass), 0 (fail) or NaN (not applicable)"),))

BUILT_IN = (GEOMETRY, SCENE, STACK_SCENE, INSTRUMENT, SYSTEM, FARADAY, FARADAY_MAP, CALIBRATION, SYSTEM_RESIDUAL,
            FARADAY_RESIDUAL, BACKSCATTER_ERROR, BACKSCATTER_BUDGET, AGB_ERROR, VERDICTS)
"""The products of e2esim's own stages, in chain order (docs/architecture.md lists them)."""
