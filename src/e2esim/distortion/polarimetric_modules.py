"""Propagation module (kind ``propagation``): the errors of sigma_hh, sigma_hv and sigma_vv together."""

from __future__ import annotations

import numpy as np

from e2esim import products as P
from e2esim.distortion.covariance_montecarlo import simulate_covariance
from e2esim.distortion.faraday_correction import FaradayCorrection
from e2esim.distortion.modules import analytic_use
from e2esim.distortion.montecarlo import METHODS, gaussianity
from e2esim.distortion.polarimetric_model import PolarimetricErrorModel
from e2esim.distortion.polarimetric_moments import REFERENCES
from e2esim.distortion.validity import VALIDITY
from e2esim.module import Stage
from e2esim.params import Param

CORRECTIONS = ("auto", "none", "perfect")


class PolarimetricErrorPropagation(Stage):
    """Errors of sigma_hh, sigma_hv and sigma_vv, their covariance, under crosstalk, channel imbalance, Faraday
    rotation and noise (docs/theory/co-pol-error.md; Men et al. 2021 for HV).

    Provides ``backscatter.error`` as a ``MultiChannelErrorModel`` (a ``PolarimetricErrorModel``): as a single
    channel it is HV, exactly the model of ``hv_backscatter_error`` in its complete form; its channel views
    and joint moments serve the multi-channel retrieval and the per-channel requirements.
    """

    kind = "propagation"
    type_name = "polarimetric_error"
    summary = "errors of sigma_hh, sigma_hv, sigma_vv and their covariance (co-pol theory, Men et al. 2021 for HV)"
    params = (
        Param("faraday_correction", "str",
              "how HH and VV treat Faraday rotation: auto (as the calibration section did: rotated back by its "
              "estimate, leaving the residual rotation of CalibrationRecord.faraday_error(); not at all without a "
              "Faraday-rotation step), none (never), perfect (by the true rotation)", default="auto",
              choices=CORRECTIONS),
        Param("reference", "str",
              "'scene': one scene, errors against its own sample covariance (eq. 17); 'population': a new scene per "
              "realisation, errors against the covariance (speckle included)", default="scene", choices=REFERENCES),
        Param("mc_method", "str", "Monte Carlo: 'fast' (exact, O(M N)) or 'brute_force' (pixel by pixel)",
              default="fast", choices=METHODS),
        Param("gaussianity", "bool", "test the simulated HV errors for Gaussianity (Men et al. 2021, Fig. 2)",
              default=True),
    )
    needs = ("scene.covariance", "system.residual", "faraday.residual")
    uses = ("calibration",)
    provides = (P.BACKSCATTER_ERROR,)

    def correction(self, case) -> tuple:
        """(FaradayCorrection, note) for the case: what the co-polarised estimates do about the rotation."""
        mode = self.si["faraday_correction"]
        record = case.get("calibration")
        if record is not None and record.representation == "residual":
            # a polarimetric step absorbed the rotation into the residual crosstalk: faraday.residual is none
            return FaradayCorrection(), ""
        if mode == "auto":
            residual = record.faraday_error() if record is not None else None
            if residual is None:
                return FaradayCorrection(), "HH and VV are not corrected for Faraday rotation (no correction step)"
            return FaradayCorrection("estimated", residual), ""
        return FaradayCorrection(mode), ""

    def forward(self, case):
        s = case.settings
        scene, system, faraday = case["scene.covariance"], case["system.residual"], case["faraday.residual"]
        correction, note = self.correction(case)
        unavailable, notes = analytic_use(self, case, system, VALIDITY["polarimetric"])
        notes = ((note,) if note else ()) + notes
        model = PolarimetricErrorModel(scene, system, faraday, correction, looks=s.looks,
                                       reference=self.si["reference"], notes=notes, unavailable=unavailable,
                                       kernel_memo=getattr(case.services, "memo", None))
        if unavailable is None:
            model.current_joint()  # evaluated here, once: every later stage reads it
        if s.montecarlo:
            mc = simulate_covariance(scene, system, faraday, case.rng, s.looks, s.realisations, s.noise_realisations,
                                     self.si["reference"], self.si["mc_method"], correction)
            gauss = None
            hv = mc.errors[..., 1]
            if self.si["gaussianity"] and np.ravel(hv).size >= 20:
                gauss = gaussianity(hv)
            model = model.with_montecarlo(mc, gauss)
        return {"backscatter.error": model}
