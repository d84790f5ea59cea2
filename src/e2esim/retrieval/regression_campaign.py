"""Regression uncertainty of a retrieval model calibrated on field plots, as a relative sigma_hv error.

A retrieval model is fitted to n reference plots; its coefficients are uncertain, and so is every AGB
it returns. For a chain case this module simulates one calibration campaign from the case's model (known
truth, ``synthetic_field_plots``: allometric error, backscatter measurement error, error in equation),
fits it -- naively with the covariance of eq. (6) (``method="delta"``), or with SIMEX and the parametric
bootstrap (eqs. 11-19, ``method="bootstrap"``) -- and returns the uncertainty of the AGB estimate at the
case's AGB as the equivalent relative sigma_hv error:

* ``mode="confidence"``: the coefficient uncertainty alone, ``S_y^2 / f^2`` at the case's AGB (eq. 4;
  for the bootstrap the robust 16-84 % spread of the bootstrap curves there, see
  ``BootstrapResult.curve_spread``);
* ``mode="prediction"``: plus the error in equation (eq. 7): the scatter of real stands around the curve.

For a multi-channel model the coefficient uncertainty is carried through the joint inversion
(gradient of ln AGB_hat with respect to the nine coefficients) and expressed as an HV-equivalent error.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.retrieval.agb_error import AGBContribution
from e2esim.retrieval.bootstrap import parametric_bootstrap
from e2esim.retrieval.simex import simex
from e2esim.retrieval.synthetic import synthetic_field_plots

REGRESSION_MODES = ("none", "confidence", "prediction")
REGRESSION_METHODS = ("delta", "bootstrap")


@dataclass(frozen=True)
class CalibrationCampaign:
    """How the retrieval model is calibrated (the ``regression`` section of a retrieval module).

    mode : "none", "confidence" or "prediction". method : "delta" or "bootstrap". plots : n.
    agb_range_t_ha : (low, high) AGB of the plots. allometric_error_fraction, backscatter_error_fraction,
    model_error_fraction : sizes of the three errors (relative SDs: of AGB, of sigma, of sigma).
    bootstrap_samples, simex_samples : B and S for ``method="bootstrap"``.
    """

    mode: str = "none"
    method: str = "delta"
    plots: int = 40
    agb_range_t_ha: tuple = (20.0, 400.0)
    allometric_error_fraction: float = 0.10
    backscatter_error_fraction: float = 0.05
    model_error_fraction: float = 0.10
    bootstrap_samples: int = 200
    simex_samples: int = 50

    def __post_init__(self):
        if self.mode not in REGRESSION_MODES:
            raise PhysicsInputError(f"regression mode must be one of {REGRESSION_MODES}, got {self.mode!r}")
        if self.method not in REGRESSION_METHODS:
            raise PhysicsInputError(f"regression method must be one of {REGRESSION_METHODS}, got {self.method!r}")


def regression_contribution(model, agb: float, campaign: CalibrationCampaign, rng: np.random.Generator,
                            covariates: dict | None = None) -> AGBContribution | None:
    """The regression uncertainty at ``agb`` (t/ha) as an ``AGBContribution`` (None for mode "none")."""
    if campaign.mode == "none":
        return None
    cov = dict(covariates or {})
    plots = synthetic_field_plots(
        model, campaign.plots, rng, agb_range_t_ha=campaign.agb_range_t_ha,
        allometric_error=campaign.allometric_error_fraction,
        backscatter_error=campaign.backscatter_error_fraction,
        model_error=campaign.model_error_fraction,
        incidence_range_rad=None if "incidence_rad" not in cov else (cov["incidence_rad"],) * 2,
    )
    fit_cov = {} if plots.incidence_rad is None else {"incidence_rad": plots.incidence_rad}
    multi = np.ndim(model.sigma(agb, **cov)) == 1
    if multi and campaign.method == "bootstrap":
        raise PhysicsInputError("regression method 'bootstrap' is implemented for single-channel models; use 'delta'")
    fit = model.fit(plots.agb, plots.sigma, **fit_cov)
    if not fit.converged:
        raise PhysicsInputError(f"the calibration fit of {campaign.plots} synthetic plots did not converge; "
                                "widen agb_range_t_ha or add plots")
    if campaign.method == "delta":
        fitted, coef_cov = fit.model, fit.covariance
        resid_var = fit.residual_variance
        if multi:
            var, pred = _multichannel_variance(fitted, coef_cov, agb, cov)
        else:
            f = float(fitted.sigma(agb, **cov))
            jac = fitted.param_jacobian(np.array([agb]), **cov)[0]
            if fit.space == "log":
                jac = jac / f
            var = float(jac @ coef_cov @ jac) / (f**2 if fit.space == "linear" else 1.0)  # eq. (4)
            pred = float(resid_var) / (f**2 if fit.space == "linear" else 1.0)
    else:
        sx = simex(model, plots.agb, plots.sigma, plots.agb_error_sd, plots.sigma_error_sd, rng,
                   n_sim=campaign.simex_samples, naive=fit)
        boot = parametric_bootstrap(sx.model, plots.agb, plots.sigma, plots.agb_error_sd, plots.sigma_error_sd, rng,
                                    n_boot=campaign.bootstrap_samples)
        # The 16-84 % spread of the bootstrap curves at the case's AGB: the sample covariance of the
        # coefficients of a poorly identified model is dominated by a few degenerate refits.
        var = float(boot.curve_spread(agb)[0]) ** 2
        f = float(sx.model.sigma(agb))
        pred = (boot.model_error.variance / f**2) if fit.space == "linear" else float(fit.residual_variance)
    total = var + (pred if campaign.mode == "prediction" else 0.0)
    what = "coefficients" + (" and error in equation" if campaign.mode == "prediction" else "")
    return AGBContribution("regression", "regression", 0.0, float(total),
                           f"retrieval-model {what}: {campaign.plots} plots, {campaign.method} (Ahmed et al. 2014, "
                           f"eqs. 3-7)")


def _multichannel_variance(model, coef_cov, agb, cov):
    """Var of ln AGB_hat from the coefficients (numerical gradient through the joint inversion) and from
    the error in equation (1 / a^T Sigma_r^-1 a), both as HV-equivalent relative sigma variances."""
    truth = model.sigma(agb, **cov)
    p = model.params
    grad = np.empty(p.size)
    for k in range(p.size):
        h = 1e-6 * max(1.0, abs(p[k]))
        up, dn = p.copy(), p.copy()
        up[k] += h
        dn[k] -= h
        lu = np.log(model.with_params(up).invert(truth[None], **cov).agb[0])
        ld = np.log(model.with_params(dn).invert(truth[None], **cov).agb[0])
        grad[k] = (lu - ld) / (2 * h)
    c_hv = model.channel_weights()[1]
    a = np.asarray(model.a)
    var_ln = float(grad @ coef_cov @ grad)
    pred_ln = 1.0 / float(a @ np.linalg.solve(model.residual_covariance, a))
    return var_ln / c_hv**2, pred_ln / c_hv**2

