"""Propagation module (kind ``propagation``): the error of sigma_hv, analytic and Monte Carlo."""

from __future__ import annotations

import dataclasses

import numpy as np

from e2esim import products as P
from e2esim.distortion.analytic import FORMS, REFERENCES, MomentInputs, no_rotation
from e2esim.distortion.error_model import HVErrorModel
from e2esim.distortion.faraday_correction import HV_UNCHANGED_BY_ROTATION
from e2esim.distortion.first_order import SceneTerms
from e2esim.distortion.montecarlo import METHODS, gaussianity, simulate
from e2esim.distortion.validity import (
    VALIDITY,
    ValidityRange,
    beyond_range,
    hard_limit_problem,
    scenario_convention,
)
from e2esim.module import Stage, fail
from e2esim.params import Param

VALIDITY_NOTE = "analytic model used beyond its validity range"
"""How a case note outside a model's measured validity range begins (``e2esim run`` repeats such notes as
warnings)."""


def analytic_caveat(system) -> str | None:
    """A remark when the analytic moments describe ``system`` only approximately (e.g. calibration residuals
    correlated outside the pairs of Men et al. 2021, Section III), or None."""
    check = getattr(system, "analytic_caveat", None)
    return check() if callable(check) else None


def in_plain_range(system, validity: ValidityRange) -> bool:
    """The analytic model describes ``system`` plainly: within its validity range, no caveat (the batched fast
    paths take such cases only; ``analytic_use`` reports the others)."""
    return beyond_range(system, validity) is None and not analytic_caveat(system)


def analytic_use(stage, case, system, validity: ValidityRange) -> tuple:
    """(why the analytic moments are not used, or None; notes) for a case of a propagation stage.

    Past the hard limit: refused in simulation mode ``analytic``, the Monte Carlo alone in ``both``. Past the
    model's measured validity range (``e2esim.distortion.validity``): the Monte Carlo alone in ``both``; in
    ``analytic`` a note beginning with ``VALIDITY_NOTE`` (a warning of ``e2esim run``). Levels are given in the
    scenario's convention and as 3-sigma labels.
    """
    s = case.settings
    if not s.analytic:
        return f"the analytic moments are not computed in simulation mode {s.mode!r}", ()
    convention = scenario_convention(case)
    problem = hard_limit_problem(system, convention)
    if problem is not None and not s.montecarlo:
        raise fail(stage, f"case {case.index}: the analytic error model does not apply: {problem}",
                   "use simulation.mode: montecarlo (or both) for this case")
    beyond = None if problem is not None else beyond_range(system, validity, convention)
    if (problem or beyond) is not None and s.montecarlo:
        why = problem or beyond
        return why, (f"analytic model not used: {why}; results from the Monte Carlo",)
    notes = () if beyond is None else (
        f"{VALIDITY_NOTE}: {beyond}; the analytic numbers are approximate: use simulation.mode both or montecarlo",)
    caveat = analytic_caveat(system)
    return None, notes + ((caveat,) if caveat else ())


class HVBackscatterErrorPropagation(Stage):
    """Error of sigma_hv under crosstalk, channel imbalance, Faraday rotation and noise.

    Men et al. (2021): analytic mean and variance (eqs. 11-12, completed to second order) and/or the
    Monte Carlo of the full system model (eq. 1, Section IV), as the simulation mode asks.
    """

    kind = "propagation"
    type_name = "hv_backscatter_error"
    summary = "sigma_hv error from system distortions, Faraday rotation and noise (Men et al. 2021)"
    params = (
        Param("variance_form", "str",
              "analytic variance: 'complete' (second order, exact average over Faraday rotation) or "
              "'paper' (eqs. 11-12 as published)", default="complete", choices=FORMS),
        Param("reference", "str",
              "'scene': one scene, error against its own sigma_hv (eq. 17, the paper's simulation); "
              "'population': a new scene per realisation, error against the covariance (speckle included)",
              default="scene", choices=REFERENCES),
        Param("mc_method", "str", "Monte Carlo: 'fast' (exact, O(M N)) or 'brute_force' (pixel by pixel)",
              default="fast", choices=METHODS),
        Param("gaussianity", "bool", "test the simulated errors for Gaussianity (Fig. 2)", default=True),
    )
    needs = ("scene.covariance", "system.residual", "faraday.residual")
    provides = (P.BACKSCATTER_ERROR,)

    def insensitivity(self, owner, key):
        """sigma_hv cannot see the settings of a Faraday-rotation correction (``HV_UNCHANGED_BY_ROTATION``)."""
        from e2esim.calibration.modules import rotation_only_setting

        calibration = getattr(owner, "kind", None) == "calibration"
        return HV_UNCHANGED_BY_ROTATION if calibration and rotation_only_setting(owner, key) else None

    @property
    def validity(self) -> ValidityRange:
        """The measured validity range of the analytic form used (docs/theory/validity.md)."""
        return VALIDITY["hv_" + self.si["variance_form"]]

    forward_takes_blocks = True

    def forward(self, case):
        """The error model of a case, or of a block of analytic cases at once (``e2esim.block.Block``; the
        one-case model of each is what it gets alone). A Monte Carlo, and cases the analytic model does not
        describe plainly (levels beyond its validity range, a caveat, a scene that is not reflection symmetric),
        run case by case (``analytic_use`` reports them)."""
        c, s = self.si, case.settings
        validity = self.validity
        plain = case.column("system.residual", f"plain analytic, {validity.model}",
                            lambda v: in_plain_range(v, validity))
        symmetric = case.column("scene.covariance", "reflection symmetric", lambda v: v.is_reflection_symmetric())
        if s.montecarlo or not s.analytic or not (np.all(plain) and np.all(symmetric)):
            case.per_case("a Monte Carlo, or cases beyond the plain analytic model")
            return self._forward_case(case)
        looks = s.looks if c["variance_form"] == "complete" else None
        model = HVErrorModel(case["scene.covariance"], case["system.residual"], case["faraday.residual"],
                             c["variance_form"], looks=looks, reference=c["reference"],
                             inputs=moment_inputs(case, c["variance_form"]))
        model.current()  # evaluated here, once: every later stage reads it
        return {"backscatter.error": model}

    def _forward_case(self, case):
        c, s = self.si, case.settings
        scene, system, faraday = case["scene.covariance"], case["system.residual"], case["faraday.residual"]
        mc = gauss = None
        unavailable, notes = analytic_use(self, case, system, self.validity)
        if unavailable is None and not scene.is_reflection_symmetric():
            raise fail(self, "the analytic error model assumes a reflection-symmetric scene (Men et al. 2021, "
                       f"Section III) but case {case.index} has HH-HV or HV-VV correlation",
                       "use simulation.mode: montecarlo for this scene")
        looks = s.looks if c["variance_form"] == "complete" else None
        model = HVErrorModel(scene, system, faraday, c["variance_form"], looks=looks, reference=c["reference"],
                             notes=notes, unavailable=unavailable)
        if unavailable is None:
            model.current()  # evaluated here, once: every later stage reads it
        if s.montecarlo:
            mc = simulate(scene, system, faraday, case.rng, looks=s.looks, realisations=s.realisations,
                          noise_realisations=s.noise_realisations, reference=c["reference"], method=c["mc_method"])
            if c["gaussianity"] and np.ravel(mc.hv).size >= 20:
                gauss = gaussianity(mc.hv)
            model = model.with_montecarlo(mc, gauss)
        return {"backscatter.error": model}


_TRIG = ("c4", "s4", "c2s2", "cs")  # FaradayDistribution.trig_moments, in its order


def moment_inputs(case, form: str) -> MomentInputs:
    """The ``MomentInputs`` of the case's scene, residual system and Faraday rotation (``MomentInputs.of``), with
    the case axis of a block: each distinct product read once (``case.column``)."""
    terms = case.column("scene.covariance", "moment terms",
                        lambda v: dataclasses.astuple(SceneTerms.from_covariance(v)))
    system = case.column("system.residual", "moment system", lambda v: (
        *v.unit_structure, float(v.crosstalk_level), float(v.imbalance_level), float(v.noise_power),
        *v.gain_power_moments, not v.has_gain_error))
    if form == "paper":
        averaging = dict(zip(_TRIG, case.column("faraday.residual", "moment trig",
                                                lambda v: tuple(v.trig_moments()[k] for k in _TRIG))))
    else:
        averaging = case.column("faraday.residual", "moment weights", lambda v: v.even_quadrature()[1])
    still = case.column("faraday.residual", "no rotation", no_rotation)
    return MomentInputs(SceneTerms(*terms), tuple(system[:5]), tuple(system[5:8]), tuple(system[8:10]), averaging,
                        still, system[10])
