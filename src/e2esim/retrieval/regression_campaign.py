"""Regression uncertainty of a retrieval model calibrated on field plots, as a relative sigma_hv error.

A retrieval model is fitted to n reference plots; its coefficients are uncertain, and so is every AGB
it returns. For a chain case this module simulates calibration campaigns from the case's model (known
truth, ``synthetic_field_plots``: allometric error, backscatter measurement error, error in equation),
fits each -- naively with the covariance of eq. (6) (``method="delta"``), or with SIMEX and the parametric
bootstrap (eqs. 11-19, ``method="bootstrap"``) -- and returns the uncertainty of the AGB estimate at the
case's AGB as the equivalent relative sigma_hv error, the expectation over ``campaigns`` campaigns with its
standard error and its spread across them (``e2esim.retrieval.campaign_ensemble``):

* ``mode="confidence"``: the coefficient uncertainty alone, ``S_y^2 / f^2`` at the case's AGB (eq. 4;
  for the bootstrap the robust 16-84 % spread of the bootstrap curves there, see
  ``BootstrapResult.curve_spread``);
* ``mode="prediction"``: plus the error in equation (eq. 7): the scatter of real stands around the curve.

For a multi-channel model the coefficient uncertainty is carried through the joint inversion
(gradient of ln AGB_hat with respect to the nine coefficients) and expressed as an HV-equivalent error.
"""

from __future__ import annotations

from dataclasses import dataclass

from e2esim.errors import PhysicsInputError
from e2esim.retrieval.agb_error import AGBContribution
from e2esim.retrieval.campaign_ensemble import ensemble

REGRESSION_MODES = ("none", "confidence", "prediction")
REGRESSION_METHODS = ("delta", "bootstrap")


@dataclass(frozen=True)
class CalibrationCampaign:
    """How the retrieval model is calibrated (the ``regression`` section of a retrieval module).

    mode : "none", "confidence" or "prediction". method : "delta" or "bootstrap". plots : n.
    agb_range_t_ha : (low, high) AGB of the plots. allometric_error_fraction, backscatter_error_fraction,
    model_error_fraction : sizes of the three errors (relative SDs: of AGB, of sigma, of sigma).
    bootstrap_samples, simex_samples : B and S for ``method="bootstrap"``. campaigns : K, the simulated
    campaigns the regression term is the expectation over (``e2esim.retrieval.campaign_ensemble``).
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
    campaigns: int = 100

    def __post_init__(self):
        if self.mode not in REGRESSION_MODES:
            raise PhysicsInputError(f"regression mode must be one of {REGRESSION_MODES}, got {self.mode!r}")
        if self.method not in REGRESSION_METHODS:
            raise PhysicsInputError(f"regression method must be one of {REGRESSION_METHODS}, got {self.method!r}")


def regression_contribution(model, agb: float, campaign: CalibrationCampaign, seed: int,
                            covariates: dict | None = None, memo=None) -> AGBContribution | None:
    """The regression uncertainty at ``agb`` (t/ha) as an ``AGBContribution`` (None for mode "none"): the
    expectation over the campaigns drawn from the run's ``seed``, with its standard error and spread
    (``AGBContribution.uncertainty``). memo : the run's ``KernelMemo``, which keeps the campaigns for the other
    cases (``campaign_ensemble.ensemble``)."""
    if campaign.mode == "none":
        return None
    drawn = ensemble(model, campaign, seed, covariates, memo)
    u = drawn.uncertainty(agb)
    what = "coefficients" + (" and error in equation" if campaign.mode == "prediction" else "")
    return AGBContribution("regression", "regression", 0.0, u.relative_variance,
                           f"retrieval-model {what}: {campaign.plots} plots, {campaign.method}, mean over "
                           f"{campaign.campaigns} simulated campaigns (Ahmed et al. 2014, eqs. 3-7)", uncertainty=u)
