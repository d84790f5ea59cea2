"""What the uncertainty product takes from a scenario where the product says nothing: the scenario's first case
is run through its chain (the reference path, ``e2esim.runner.cases.run_case``) and its products give the
system-error model before and after calibration, the scene, the Faraday rotation, the retrieval's exponent and
the AGB error bound. Without ``--scenario`` the shipped assumptions of the product's mission are used
(``assumptions/biomass.yaml``, ``assumptions/nisar.yaml`` beside this file)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from e2esim.errors import ConfigError, Location
from e2esim.runner.cases import run_case
from e2esim.runner.scenario import Scenario

DEFAULT_FR_WINDOW_LOOKS = 10_000
"""Independent samples in a Faraday-rotation estimation window where the scenario has no faraday_correction
step: the default of that step (2 km x 2 km for BIOMASS, calibration.faraday_correction.looks)."""

SHIPPED = Path(__file__).with_name("assumptions")


@dataclass(frozen=True)
class Assumptions:
    """source : the scenario file. system, system_residual : ``SystemErrorModel`` before and after the scenario's
    calibration. scene : ``ScatteringCovariance``. faraday : ``FaradayDistribution`` of the geophysical rotation.
    exponent : p of the power law. bound, confidence : the AGB error bound (fraction) and its confidence.
    fr_window_looks : samples in a Faraday-rotation estimation window."""

    source: str
    system: object
    system_residual: object
    scene: object
    faraday: object
    exponent: float
    bound: float
    confidence: float
    fr_window_looks: int

    def attributes(self) -> dict:
        """The assumptions as the outputs' attributes list them (SI; the scenario named)."""
        return {
            "assumptions_scenario": self.source,
            "assumed_crosstalk_variance": self.system.crosstalk_level,
            "assumed_crosstalk_variance_after_calibration": self.system_residual.crosstalk_level,
            "assumed_imbalance_variance": self.system.imbalance_level,
            "assumed_imbalance_variance_after_calibration": self.system_residual.imbalance_level,
            "assumed_scene": self.scene.label,
            "assumed_faraday_rotation_mean_rad": self.faraday.mean_rad,
            "assumed_faraday_rotation_sd_rad": self.faraday.sd_rad,
            "assumed_power_law_exponent": self.exponent,
            "assumed_agb_error_bound": self.bound,
            "assumed_agb_error_confidence": self.confidence,
            "assumed_faraday_window_looks": self.fr_window_looks,
        }


def load_assumptions(scenario_path, mission: str) -> Assumptions:
    path = Path(scenario_path) if scenario_path is not None else SHIPPED / f"{mission}.yaml"
    source = str(scenario_path) if scenario_path is not None else f"e2esim:products_io/assumptions/{mission}.yaml"
    resolved = Scenario.load(path).resolve()
    case = resolved.cases[0]
    products = run_case(case).products
    where = Location(source, ())
    for needed in ("system", "system.residual", "scene.covariance", "faraday.geophysical", "agb.error"):
        if needed not in products:
            raise ConfigError(where, f"the scenario provides no {needed!r}, which the uncertainty product needs",
                              "a scenario with scene, instrument, ionosphere, propagation and retrieval sections")
    agb = products["agb.error"]
    if agb.mapping is not None:
        raise ConfigError(Location(source, ("retrieval",)), "the uncertainty product supports the power law only",
                          "retrieval: {type: power_law}")
    bounds = [m for m in case.modules if m.kind == "requirement" and m.type_name == "agb_error_bound"]
    if not bounds:
        raise ConfigError(Location(source, ("requirements",)), "no agb_error_bound requirement",
                          "one agb_error_bound requirement: the bound each pixel's verdict checks")
    corrections = [m for m in case.modules if m.type_name == "faraday_correction"]
    looks = int(corrections[0].si["looks"]) if corrections else DEFAULT_FR_WINDOW_LOOKS
    return Assumptions(source, products["system"], products["system.residual"], products["scene.covariance"],
                       products["faraday.geophysical"], float(agb.exponent), float(bounds[0].si["bound_fraction"]),
                       float(bounds[0].si["confidence_fraction"]), looks)
