"""Calibration modules (kind ``calibration``): the steps of a calibration strategy.

A scenario's ``calibration`` section is one module or a list applied in order. Each module contributes
correction steps (``steps``); the calibration stage (``e2esim.calibration.stage``) simulates the whole
strategy on calibration data drawn through the full system model (distributed-target windows, calibrators
in clutter) and provides the residual errors beside the raw ones: what the estimators' errors leave, not
the raw instrument errors (``e2esim.calibration.record`` explains the representation).
"""

from __future__ import annotations

import numpy as np

from e2esim import registry
from e2esim.calibration.radiometric import (
    UNIFORM_ARRAY_BEAM_SHAPING,
    absolute_gain_error_db,
    swath_pointing_gain_sd_db,
)
from e2esim.calibration.steps import FaradayStep, GainStep, QueganStep, TransponderStep, TrihedralStep
from e2esim.calibration.targets import TARGET_NAMES, Calibrators, target_matrix
from e2esim.calibration.transponder import GAUGES
from e2esim.errors import PhysicsInputError
from e2esim.faraday.distribution import GaussianFaraday
from e2esim.key_paths import override_path
from e2esim.module import Module, fail
from e2esim.params import Param
from e2esim.polarimetry.system_model import to_vector

CLUTTER_SHAPES = {
    # Reflection-symmetric clutter around a calibrator (hh, hv, vv): equal co-polarised powers, HV 10 dB
    # below, HH-VV correlation 0.6. Illustrative of low vegetation; only the ratios matter, the SCR sets
    # the level.
    "low_vegetation": np.array([[1.0, 0.0, 0.6], [0.0, 0.1, 0.0], [0.6, 0.0, 1.0]], dtype=complex),
}
CLUTTER_CHOICES = (*CLUTTER_SHAPES, "scene")
PRIORS = ("climatology", "tec_map")


def rotation_only_setting(strategy, key: str) -> bool:
    """Whether ``key`` sets a parameter of a ``faraday_correction`` step of ``strategy`` (a ``CalibrationStrategy``)
    whose other steps correct no polarimetric distortion: it then changes only the Faraday rotation left in the data
    (the "rotation_invariant" record of ``e2esim.calibration.record``), not the residual system errors."""
    path = override_path(key)
    modules = getattr(strategy, "modules", ())
    if not all(type(m) in (FaradayCorrection, NoCalibration, RadiometricCalibration) or type(m).rotation_only
               for m in modules):
        return False
    for m in modules:
        where = tuple(m.location.key_path)
        inside = path[:len(where)] == where and path[len(where):][:1] not in ((), ("type",))
        if (isinstance(m, FaradayCorrection) or type(m).rotation_only) and inside:
            return True
    return False


class CalibrationModule(Module):
    """Base class: a module contributes one or more steps of the calibration strategy (``steps``).

    ``needs`` and ``uses`` name the products its steps read (the stage adds them to its own).
    """

    kind = "calibration"
    rotation_only = False  # True: its settings change only the Faraday rotation left in the data (residual_faraday)
    needs = ("system", "faraday.geophysical", "scene.covariance")
    uses = ("instrument",)

    def steps(self, case) -> list:
        """``[(name, CalibrationStep), ...]`` this module adds (override; none for ``calibration: none``)."""
        return []

    def _clutter(self, case) -> np.ndarray:
        name = self.si["clutter"]
        return case["scene.covariance"].matrix if name == "scene" else CLUTTER_SHAPES[name]


class NoCalibration(CalibrationModule):
    """No calibration: the propagation sees the instrument's errors and the full Faraday rotation."""

    type_name = "none"
    summary = "no calibration: raw crosstalk, channel imbalance, gain and Faraday rotation"
    needs = ("system", "faraday.geophysical")


class FaradayCorrection(CalibrationModule):
    """Estimate Omega on the scene and rotate it away, ``S = F^-1 M F^-1`` (Quegan et al. 2018, eq. 4).

    The estimator is a registered ``faraday_estimator`` module (``e2esim.faraday.estimator_modules``):
    Bickel-Bates (circular basis; variance eqs. 5-6, corrected in docs/errata.md), Freeman's second-moment
    estimator, or the chirp slope (eq. 12). The pi/2 ambiguity is resolved with a prior: the ionosphere
    module's mean (``climatology``) or a TEC-map prediction with an error SD (``tec_map``). On its own
    this leaves the sigma_hv error unchanged (the estimator (M_hv + M_vh)/2 is rotation invariant); the
    residual Faraday rotation is reported and matters to the steps that follow.
    """

    type_name = "faraday_correction"
    summary = "Faraday-rotation correction by Bickel-Bates, Freeman or chirp-slope estimates over N looks"
    params = (
        Param("estimator", "module", "Faraday-rotation estimator: a faraday_estimator type (bickel_bates, freeman, "
              "chirp_slope) or a mapping with its type and parameters, e.g. {type: chirp_slope, subbands: 8}",
              default="bickel_bates", kind="faraday_estimator", lookup=registry.lookup),
        Param("looks", "int", "independent samples in the estimation window (10^4: 2 km x 2 km for BIOMASS, "
              "Quegan et al. 2018, Sect. 6)", default=10_000, minimum=1, maximum=10**9),
        Param("prior", "str", "prior that resolves the pi/2 ambiguity: the ionosphere module's mean, or a "
              "TEC-map prediction with error prior_sd_deg", default="climatology", choices=PRIORS),
        Param("prior_sd_deg", "float", "SD of the TEC-map prediction of Omega (prior: tec_map)", default=10.0,
              unit="deg", minimum=0.0, maximum=180.0),
    )

    def setup(self):
        self.si["estimator"].check_window(self.si["looks"])

    def steps(self, case):
        estimator = self.si["estimator"]
        inst = case.get("instrument")
        if estimator.needs_frequency and (inst is None or not (inst.centre_frequency_hz > 0 and inst.bandwidth_hz > 0)):
            raise fail(self, f"{estimator.type_name} needs the instrument's centre frequency and bandwidth",
                       "use an instrument module that gives centre_frequency_mhz and bandwidth_mhz", key="estimator")
        step = FaradayStep(estimator, self.si["looks"], self.si["prior"], self.si["prior_sd_rad"], inst)
        return [(self.type_name, step)]


class DistributedTargetCalibration(CalibrationModule):
    """Crosstalk and f1/f2 from the scene by Quegan (1994), and optionally f1 f2 from trihedrals.

    Needs reflection symmetry, a signal well above the noise and small Faraday rotation (Quegan et al.
    2018, Sect. 5.2; one pass absorbs up to about 12 deg, five passes up to 40 deg): put
    ``faraday_correction`` before it away from the magnetic equator. Its estimates are biased by about
    sigma_hv/sigma_co times the crosstalk (P-band forest: 0.1-0.4); ``iterations > 1`` re-estimates on the
    corrected data and removes most of it (it converges for the Table I forests). A distributed target cannot give the
    co-polarised imbalance f1 f2 (the term that dominates the sigma_hv variance): ``trihedral: true`` takes
    it from trihedrals in the scene at the given signal-to-clutter ratio.
    """

    type_name = "distributed_target_calibration"
    summary = "crosstalk and channel imbalance from distributed targets (Quegan 1994) plus optional trihedrals"
    params = (
        Param("looks", "int", "independent samples of the distributed target used", default=100_000, minimum=1,
              maximum=10**9),
        Param("iterations", "int", "passes of the algorithm on its own corrected data (1: Quegan 1994)", default=1,
              minimum=1, maximum=50),
        Param("subtract_noise", "bool", "subtract the known noise power from the co-polarised powers", default=True),
        Param("trihedral", "bool", "measure the co-polarised imbalance f1 f2 on trihedrals in the scene",
              default=False),
        Param("trihedral_scr_db", "float", "signal-to-clutter ratio of each trihedral", default=30.0, unit="dB",
              minimum=-20.0, maximum=100.0),
        Param("trihedral_count", "int", "independent trihedrals (or passes) averaged", default=1, minimum=1,
              maximum=10_000),
        Param("absolute_gain", "bool", "also set the absolute gain from the trihedrals (else keep the "
              "instrument's gain statistics)", default=False),
        Param("snr_db", "float", "calibrator peak power over the noise per channel", default=50.0, unit="dB",
              minimum=-20.0, maximum=200.0),
        Param("clutter", "str", "clutter shape around the calibrators", default="low_vegetation",
              choices=CLUTTER_CHOICES),
    )

    def steps(self, case):
        c = self.si
        out = [(self.type_name, QueganStep(c["looks"], c["iterations"], c["subtract_noise"]))]
        if c["trihedral"]:
            cal = Calibrators.from_ratios(["trihedral"] * c["trihedral_count"], c["trihedral_scr_linear"],
                                          self._clutter(case), 1.0 / c["snr_linear"])
            out.append((self.type_name + ".trihedral", TrihedralStep(cal, c["absolute_gain"])))
        return out


class TransponderCalibration(CalibrationModule):
    """delta1..4, f1, f2, Omega and the gain from four or more calibrators by non-linear least squares
    (Quegan et al. 2018, Sect. 5.1), at any Faraday rotation; the crosstalk/Faraday-rotation ambiguity is
    fixed by ``gauge`` (``e2esim.calibration.transponder``). The system errors are stable, so the estimates
    correct the scene; its own Faraday rotation needs a ``faraday_correction`` step, unless the calibrators
    are in the scene (``site_faraday_mean_deg: null``) and ``correct_faraday`` is set."""

    type_name = "transponder_calibration"
    summary = "all system errors from >= 4 polarimetric calibrators by non-linear least squares"
    params = (
        Param("calibrators", "str", "calibrators seen", variable_length=True, choices=TARGET_NAMES,
              default=("transponder_hh", "transponder_hv", "transponder_vh", "transponder_vv")),
        Param("scr_db", "float", "signal-to-clutter ratio of each calibrator", default=30.0, unit="dB",
              minimum=-20.0, maximum=100.0),
        Param("snr_db", "float", "calibrator peak power over the noise per channel", default=50.0, unit="dB",
              minimum=-20.0, maximum=200.0),
        Param("clutter", "str", "clutter shape around the calibrators", default="low_vegetation",
              choices=CLUTTER_CHOICES),
        Param("gauge", "str", "condition that separates Faraday rotation from crosstalk", default="min_crosstalk",
              choices=GAUGES),
        Param("faraday_prior_sd_deg", "float", "SD of the independent Omega estimate (gauge: faraday_prior)",
              default=0.5, unit="deg", minimum=0.0, maximum=90.0),
        Param("site_faraday_mean_deg", "float", "mean Omega at the calibration site (null: calibrators in the scene)",
              default=None, unit="deg", minimum=-180.0, maximum=180.0, nullable=True),
        Param("site_faraday_sd_deg", "float", "SD of Omega at the calibration site", default=0.0, unit="deg",
              minimum=0.0, maximum=90.0),
        Param("correct_faraday", "bool", "also rotate the scene by the Omega found (calibrators in the scene)",
              default=False),
        Param("absolute_gain", "bool", "the calibrators are also the absolute radiometric reference (their RCS "
              "known): the HV gain is then measured directly by the HV response (false: keep the instrument's "
              "absolute gain, correct only relative to HH)", default=True),
    )

    def setup(self):
        names = self.si["calibrators"]
        if len(names) < 3:
            raise PhysicsInputError(f"{len(names)} calibrators cannot determine the system errors; give at least "
                                    "three independent ones (four or more over-determine it)", key="calibrators")
        rank = np.linalg.matrix_rank(np.stack([to_vector(target_matrix(n)) for n in names]))
        if rank < 3:
            raise PhysicsInputError(
                f"calibrators {', '.join(names)} span only {rank} independent scattering matrices; the system errors "
                "need at least 3 (e.g. trihedral, dihedral_0 and dihedral_45, or four transponders)", key="calibrators")

    def steps(self, case):
        c = self.si
        cal = Calibrators.from_ratios(c["calibrators"], c["scr_linear"], self._clutter(case), 1.0 / c["snr_linear"])
        site = None
        if c["site_faraday_mean_rad"] is not None:
            site = GaussianFaraday(c["site_faraday_mean_rad"], c["site_faraday_sd_rad"])
        try:
            step = TransponderStep(cal, c["gauge"], site, c["faraday_prior_sd_rad"], c["correct_faraday"],
                                   c["absolute_gain"])
        except PhysicsInputError as exc:
            raise fail(self, str(exc), key="calibrators") from exc
        return [(self.type_name, step)]


class RadiometricCalibration(CalibrationModule):
    """Absolute gain from point targets of known RCS, with antenna-pattern/pointing and stability terms
    (Quegan et al. 2018, Sect. 4; Ahmed et al. 2014, eqs. 30-35): sets the residual gain error."""

    type_name = "radiometric_calibration"
    summary = "absolute gain from point targets (SCR, count), antenna pattern and pointing, stability"
    params = (
        Param("scr_db", "float", "signal-to-clutter ratio of each reference target", default=30.0, unit="dB",
              minimum=-20.0, maximum=100.0),
        Param("targets", "int", "independent reference targets (or passes) averaged", default=1, minimum=1,
              maximum=100_000),
        Param("background_subtraction", "bool", "subtract the clutter power measured around the target",
              default=True),
        Param("pointing_sd_deg", "float", "SD of the residual elevation pointing error", default=0.0, unit="deg",
              minimum=0.0, maximum=10.0),
        Param("elevation_beamwidth_deg", "float", "elevation half-power beamwidth", default=5.0, unit="deg",
              exclusive_minimum=0.0, maximum=90.0),
        Param("beam_shaping", "float", "beam-shaping factor k of the sinc pattern (1.136: uniform array, "
              "Ahmed et al. 2014)", default=UNIFORM_ARRAY_BEAM_SHAPING, exclusive_minimum=0.5, maximum=3.0),
        Param("swath_fraction", "float", "part of the half-power beam the swath spans", default=1.0,
              exclusive_minimum=0.0, maximum=1.0),
        Param("drift_sd_db", "float", "gain stability between calibrations (SD)", default=0.0, unit="dB",
              minimum=0.0, maximum=10.0, convert=False),
    )

    def gain_error_db(self) -> tuple[float, float]:
        """(mean, SD) of the error of the estimated |A|^2, dB."""
        c = self.si
        pointing = swath_pointing_gain_sd_db(c["pointing_sd_rad"], c["elevation_beamwidth_rad"], c["beam_shaping"],
                                             c["swath_fraction"])
        return absolute_gain_error_db(c["scr_linear"], c["targets"], c["background_subtraction"], pointing,
                                      c["drift_sd_db"])

    def steps(self, case):
        mean, sd = self.gain_error_db()
        return [(self.type_name, GainStep(sd_db=sd, offset_db=mean))]
