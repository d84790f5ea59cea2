"""The per-pixel error budget: the batched engine's analytic kernel of the sigma_hv error (Men et al. 2021, eqs.
(11)-(12) completed to second order, ``e2esim.distortion.analytic.moments_of``) evaluated with one "case" per
pixel, so that a pixel gets the numbers the per-case model (``hv_error_moments``) gives for its scene, system and
Faraday rotation; the Faraday-rotation estimate's SD from the Bickel-Bates theory (Quegan et al. 2018, eq. 5
corrected: ``e2esim.faraday.theory.bickel_bates_variance``, asymptotic form) and the relative AGB error through the
power law (Men et al. 2021, eqs. 15-16, 19: ``e2esim.retrieval.agb_error.AGBError``); the errors of sigma_hh and
sigma_vv from the co-polarised model (``polarimetric_error_moments``, co-pol eqs. 3.2-3.6 and 4.2, its O(V^3) and
O(V^4) terms included) vectorised over pixels (``e2esim.distortion.polarimetric_pixels``), with the rotation left
in the data as the Faraday distribution and no correction: the rotation of the distortion matrices by a
processor's correction (co-pol sec. 4) is not modelled.

What is taken from where (docs/real-data.md): the scene (sigma_hh, sigma_hv, sigma_vv, <S_hh S_vv*>) and the
number of looks from the product where it holds them (NISAR GCOV), else from the scenario; the noise (NESZ) from
the product; the Faraday rotation: where the processor corrected it, the residual is the estimate's error, Gaussian
with mean 0 and the SD of the estimate (the product's own layer where it holds values, else the Bickel-Bates SD of a
window of the scenario's ``looks`` at the pixel's SNR); where it did not, the full rotation counts: the product's
own estimate (BIOMASS ``faradayRotation``) with that SD, or the scenario's geophysical rotation less any constant
the processor removed (NISAR ``faradayRotation``). The system errors: the scenario's residual after calibration
where the product corrected crosstalk (non-zero crosstalk values; a NISAR RSLC's tables pixel by pixel at its slant
range, ``e2esim.products_io.nisar_budget_terms``), the scenario's raw system where it did not. The RFI mitigation's
blanked time (BIOMASS annotation ``percentageAffectedLines``; NISAR ``rfiLikelihood``) as a gain loss of every
channel (``with_gain``).
"""

from __future__ import annotations

import numpy as np

from e2esim.distortion.analytic import MomentInputs, moments_of
from e2esim.distortion.first_order import SceneTerms
from e2esim.distortion.polarimetric_pixels import pixel_model_for
from e2esim.faraday.distribution import EVEN_WEIGHTS
from e2esim.faraday.theory import bickel_bates_variance
from e2esim.retrieval.agb_error import AGBError

SD_FROM_PRODUCT, SD_FROM_THEORY = 1, 2
"""Values of ``faraday_rotation_sd_source``: the product's own layer, or e2esim's Bickel-Bates estimate (the layer
was empty: the BPS writes ``faradayRotationStd`` as its no-data fill)."""
NO_DATA_VERDICT = 255
LAYERS = {
    # name: (units, what)
    "sigma_hv_error_mean": ("m2 m-2", "mean error of sigma_hv (systematic: crosstalk, imbalance, Faraday "
                                      "rotation, noise bias)"),
    "sigma_hv_error_sd": ("m2 m-2", "SD of the sigma_hv error (system errors, Faraday rotation, finite looks)"),
    "sigma_hv_relative_error_mean": ("1", "mean error of sigma_hv over sigma_hv"),
    "sigma_hv_relative_error_sd": ("1", "SD of the sigma_hv error over sigma_hv"),
    "faraday_rotation_sd": ("rad", "SD of the Faraday-rotation estimate (the product's own, or filled by e2esim)"),
    "faraday_rotation_sd_source": ("1", "1: the product's faradayRotationStd; 2: filled by e2esim (Bickel-Bates)"),
    "residual_faraday_rotation_mean": ("rad", "mean one-way Faraday rotation left in the data"),
    "residual_faraday_rotation_sd": ("rad", "SD of the one-way Faraday rotation left in the data"),
    "agb_relative_error": ("1", "relative AGB error at the bound's confidence (larger of the two tails)"),
    "verdict": ("1", "1: the AGB error bound holds; 0: it does not; 255: no data"),
    **{f"sigma_{ch}_{kind}": (units, f"{what} (sigma_{ch}; the co-polarised model, module docstring)")
       for ch in ("hh", "vv") for kind, units, what in (
           ("error_mean", "m2 m-2", "mean error"), ("error_sd", "m2 m-2", "SD of the error"),
           ("relative_error_mean", "1", "mean relative error"),
           ("relative_error_sd", "1", "SD of the relative error"))},
}


def pixel_moments(block, pixels, assumptions, memo) -> dict:
    """The layers (``LAYERS``) of one ``PixelBlock``, arrays of the block's shape (NaN, or 255, where invalid).
    memo : the evaluating process's ``KernelMemo`` (its pixel models, ``pixel_model_for``)."""
    shape = block.valid.shape
    ok = block.valid.ravel()
    n = int(ok.sum())
    out = {name: np.full(shape, np.nan, dtype=np.float64) for name in LAYERS}
    out["verdict"] = np.full(shape, NO_DATA_VERDICT, dtype=np.uint8)
    if n == 0:
        return out

    def take(x):
        return np.asarray(x).ravel()[ok]

    if block.sigma is not None:
        hh, hv, vv = (take(s).astype(np.float64) for s in block.sigma)
        hhvv = take(block.hhvv).astype(np.complex128)
    else:
        c = assumptions.scene.matrix
        hh, hv, vv, hhvv = (np.full(n, v) for v in (c[0, 0].real, c[1, 1].real, c[2, 2].real, c[0, 2]))
    noise = take(block.noise_power).astype(np.float64)
    fr_sd, source = faraday_estimate_sd(hh, vv, hhvv, noise, block, take, assumptions.fr_window_looks)
    fr_mean, fr_spread = residual_faraday(pixels, block, take, fr_sd, assumptions.faraday, n)
    looks = None if block.looks is None else take(block.looks).astype(np.float64)
    corrected = (np.full(n, pixels.crosstalk_applied) if block.crosstalk_corrected is None
                 else take(block.crosstalk_corrected).astype(bool))
    values = {"faraday_rotation_sd": fr_sd, "faraday_rotation_sd_source": source,
              "residual_faraday_rotation_mean": fr_mean, "residual_faraday_rotation_sd": fr_spread}
    gain = 1.0 - pixels.rfi_blanked_fraction
    # the scenario's residual after calibration where crosstalk was corrected, its raw system where it was not
    for flag, system in ((True, assumptions.system_residual), (False, assumptions.system)):
        part = corrected == flag
        if not part.any():
            continue
        whole = bool(part.all())
        inputs = (hh, hv, vv, hhvv, noise, fr_mean, fr_spread, looks)
        if not whole:
            inputs = tuple(None if x is None else x[part] for x in inputs)
        budget = system_layers(*inputs, system, gain, assumptions, memo)
        for name, value in budget.items():
            if whole:
                values[name] = value
            else:
                values.setdefault(name, np.empty(n, value.dtype))[part] = value
    for name, value in values.items():
        out[name].reshape(-1)[ok] = value
    return out


def system_layers(hh, hv, vv, hhvv, noise, fr_mean, fr_spread, looks, system, gain, assumptions, memo) -> dict:
    """The layers that depend on the system errors, for pixels that share ``system``."""
    m = moments_of(pixel_inputs(hh, hv, vv, hhvv, noise, fr_mean, fr_spread, system), "complete", looks=looks)
    mean, sd = with_gain(m.mean, np.sqrt(m.variance), hv, gain)
    agb = AGBError.from_sigma_errors(assumptions.exponent, hv, mean, sd)
    tails = agb.quantile(np.array([1.0 - assumptions.confidence, assumptions.confidence]))
    agb_error = np.max(np.abs(tails), axis=-1)
    return {
        "sigma_hv_error_mean": mean, "sigma_hv_error_sd": sd, "sigma_hv_relative_error_mean": mean / hv,
        "sigma_hv_relative_error_sd": sd / hv,
        **copol_layers(hh, hv, vv, hhvv, noise, fr_mean, fr_spread, system, looks, memo, gain),
        "agb_relative_error": agb_error, "verdict": (agb_error <= assumptions.bound).astype(np.uint8),
    }


def with_gain(mean, sd, sigma, gain):
    """Mean and SD of the error of a channel whose intensity is multiplied by a known ``gain`` g (the RFI
    mitigation's blanked time, not restored): E[e'] = g E[e] - (1 - g) sigma, SD[e'] = g SD[e] (``FixedGain``,
    e2esim.error_terms.effects; docs/theory/rfi.md). g = 1 leaves both as they are, bit for bit."""
    if gain == 1.0:
        return mean, sd
    return gain * mean - (1.0 - gain) * sigma, gain * sd


def copol_layers(hh, hv, vv, hhvv, noise, fr_mean, fr_sd, system, looks, memo, gain=1.0) -> dict:
    """The sigma_hh and sigma_vv layers: ``polarimetric_error_moments`` (co-pol eqs. 3.2-3.6, 4.2, 5.1-5.4) with the
    rotation left in the data as a Gaussian ``GaussianFaraday(fr_mean, fr_sd)`` and no correction, vectorised over
    pixels (``e2esim.distortion.polarimetric_pixels``), its model found again in ``memo``."""
    scene = np.stack([hh, hv, vv, hhvv.real, hhvv.imag], axis=-1)
    mean, var = pixel_model_for(system, memo).moments(scene, fr_mean, fr_sd, noise, looks)
    sd = np.sqrt(np.clip(var, 0.0, None))
    out = {}
    for ch, p, sigma in (("hh", 0, hh), ("vv", 2, vv)):
        m, s = with_gain(mean[:, p], sd[:, p], sigma, gain)
        out |= {f"sigma_{ch}_error_mean": m, f"sigma_{ch}_error_sd": s, f"sigma_{ch}_relative_error_mean": m / sigma,
                f"sigma_{ch}_relative_error_sd": s / sigma}
    return out


def faraday_estimate_sd(hh, vv, hhvv, noise, block, take, window_looks):
    """SD (rad) of the Faraday-rotation estimate: the product's own where it holds a value, else the Bickel-Bates
    SD over ``window_looks`` samples at the pixel's SNR <|S_hh + S_vv|^2> / (4 sigma_n) (Quegan et al. 2018,
    eq. 6; ``bickel_bates_snr``)."""
    with np.errstate(divide="ignore"):
        snr = (hh + vv + 2 * hhvv.real) / (4 * noise)
    theory = np.sqrt(bickel_bates_variance(snr, window_looks, form="asymptotic"))
    own = np.full(hh.shape, np.nan) if block.faraday_sd is None else take(block.faraday_sd).astype(np.float64)
    has_own = np.isfinite(own)
    return np.where(has_own, own, theory), np.where(has_own, SD_FROM_PRODUCT, SD_FROM_THEORY)


def residual_faraday(pixels, block, take, fr_sd, geophysical, n):
    """Mean and SD (rad) of the one-way Faraday rotation left in the data (module docstring)."""
    if pixels.faraday_applied and block.faraday_mean is not None:
        return np.zeros(n), fr_sd
    if block.faraday_mean is not None:
        return take(block.faraday_mean).astype(np.float64), fr_sd
    removed = pixels.facts.get("faraday_rotation_applied_rad", 0.0)
    return np.full(n, geophysical.mean_rad - removed), np.full(n, geophysical.sd_rad)


def pixel_inputs(hh, hv, vv, hhvv, noise, fr_mean, fr_sd, system) -> MomentInputs:
    """``MomentInputs`` with one case per pixel: what ``MomentInputs.of`` builds for one scene, system and
    ``GaussianFaraday(fr_mean, fr_sd)`` (the circular moments exp(i k mean - k^2 sd^2 / 2), Men et al. 2021
    eq. 10, into the weights of ``FaradayDistribution.even_quadrature``), stacked over pixels."""
    n = hh.size
    terms = SceneTerms(hh, hv, vv, np.abs(hhvv), np.angle(hhvv))
    # the system's structure and levels once (one "case"), broadcast over the pixels by ``moments_of``
    structure = tuple(np.asarray(s)[None] for s in system.unit_structure)
    k = np.array([2.0, 4.0, 6.0, 8.0])
    phi = np.real(np.exp(1j * k * fr_mean[:, None] - 0.5 * (k * fr_sd[:, None]) ** 2))
    moments = np.stack([np.ones(n), phi[:, 0], (1 + phi[:, 1]) / 2, (3 * phi[:, 0] + phi[:, 2]) / 4,
                        (3 + 4 * phi[:, 1] + phi[:, 3]) / 8], axis=-1)
    weights = moments @ EVEN_WEIGHTS.T
    g1, g2 = system.gain_power_moments
    levels = (np.full(1, system.crosstalk_level), np.full(1, system.imbalance_level), noise)
    return MomentInputs(terms, structure, levels, (np.full(n, g1), np.full(n, g2)), weights,
                        (fr_mean == 0.0) & (fr_sd == 0.0), np.full(n, not system.has_gain_error))
