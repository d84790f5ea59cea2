"""A propagation module of the plug-in: e2esim's sigma_hv error model with amplitude scintillation added."""

from __future__ import annotations

from e2esim.distortion.modules import HVBackscatterErrorPropagation
from e2esim_example_scintillation.error_model import ScintillationErrorModel


class HVWithScintillation(HVBackscatterErrorPropagation):
    """The sigma_hv error of Men et al. (2021) (e2esim's ``hv_backscatter_error``) times a gamma intensity
    factor of mean 1 and variance S4^2 / N (``e2esim_example_scintillation.products.Scintillation``)."""

    type_name = "hv_with_scintillation"
    summary = "sigma_hv error with amplitude scintillation as a multiplicative factor (example plug-in)"
    needs = (*HVBackscatterErrorPropagation.needs, "ionosphere.scintillation")

    def forward(self, case):
        base = super().forward(case)["backscatter.error"]
        variance = case["ionosphere.scintillation"].variance
        factors = None
        samples = base.relative_samples()
        if samples is not None and variance > 0:  # gamma with shape 1/V and mean 1: the mean of N Nakagami powers
            factors = case.rng.gamma(1.0 / variance, variance, samples.shape)
        return {"backscatter.error": ScintillationErrorModel(base, variance, factors)}
