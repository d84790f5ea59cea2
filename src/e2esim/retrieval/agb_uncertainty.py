"""The uncertainty of the answers of an ``AGBError`` (``e2esim.retrieval.agb_error``): every sampled number
with its standard error.

Two sources: the Monte Carlo's sampling error (``e2esim.retrieval.sampling_error``: cluster-robust standard
errors of means, RMSEs by the delta method, proportions, and order-statistic intervals of quantiles), and
the error of the variance terms that are themselves estimates from simulation (the regression term, the
expectation over simulated calibration campaigns, ``e2esim.retrieval.campaign_ensemble``), propagated into
every answer by moving their variance by +- its standard error. The analytic answers carry only the second;
the Monte Carlo both, in quadrature. Analytic answers without sampled terms are exact for their model
(their approximations are a matter of validity, not of sampling) and carry none.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from e2esim.case_values import plain
from e2esim.distortion.validation import sample_moments
from e2esim.retrieval import sampling_error as se


class SampledAnswers:
    """Mixin of ``AGBError``: standard errors of its mean, RMSE, quantiles and exceedance probabilities."""

    @property
    def has_sampled_terms(self) -> bool:
        """Whether a contribution's variance is itself an estimate with a standard error (the regression's
        expectation over simulated campaigns)."""
        return any(c.uncertainty is not None for c in self.contributions)

    def standard_error(self, statistic: str, basis: str = "analytic", *args, **options):
        """Standard error of ``statistic`` ("mean", "rmse", "quantile", "exceedance"; ``args`` as the method
        takes them, e.g. the probability) on ``basis``: the analytic answer's from the standard errors of the
        sampled variance terms (``terms_standard_error``); the Monte Carlo's from its sampling error and those
        terms, in quadrature (the Monte Carlo draws the terms with their estimated variance). ``options``: keyword
        arguments of the analytic answer (the exceedance's ``relative_threshold``)."""
        terms = self.terms_standard_error(lambda a: getattr(a, statistic)(*args, basis="analytic", **options))
        if basis == "analytic":
            return terms
        sampling = self.sampling_standard_error(statistic, *args)
        return plain(np.sqrt(np.square(sampling) + np.square(terms)))

    def sampling_standard_error(self, statistic: str, *args):
        """Monte Carlo sampling standard error of ``statistic`` (``e2esim.retrieval.sampling_error``)."""
        q, m = self.samples, self.realisations
        if statistic == "mean":
            return se.mean_standard_error(q, m)
        if statistic == "rmse":
            return se.rmse_standard_error(q, m)
        if statistic == "quantile":
            return plain(se.quantile_interval(q, args[0], m)[2])
        if statistic == "exceedance":
            bound, side = args[0], (args[1] if len(args) > 1 else "over")
            return se.proportion_standard_error(q > bound if side == "over" else q < -bound, m)
        raise ValueError(f"no standard error for {statistic!r}")

    def terms_standard_error(self, value_of):
        """Standard error of an analytic answer ``value_of(agb_error)`` from the standard errors of the sampled
        variance terms: half the change of the answer when their variance moves by +- its standard error
        (their standard errors in quadrature); 0 when no term is sampled."""
        terms = [np.square(np.asarray(c.uncertainty.standard_error, dtype=float)) for c in self.contributions
                 if c.uncertainty is not None]
        v_se = np.sqrt(sum(terms)) if terms else 0.0  # element-wise: a block's cases get their own numbers
        if not np.any(v_se) or self.error_sd is None:
            return 0.0
        var = np.square(self.error_sd)
        shift = np.square(self.sigma_hv) * v_se
        up = replace(self, error_sd=plain(np.sqrt(var + shift)))
        down = replace(self, error_sd=plain(np.sqrt(np.maximum(var - shift, 0.0))))
        return plain(np.abs(np.asarray(value_of(up)) - np.asarray(value_of(down))) / 2.0)


def uncertainty_scalars(agb, quantiles: dict) -> dict:
    """The standard errors of the ``agb.<basis>.*`` scalars (``*_standard_error_percent``): always for the Monte
    Carlo, for the analytic model when a variance term is sampled (the regression); and of the regression term,
    ``contribution.regression.sigma_sd_standard_error_percent``, its spread across campaigns
    (``sigma_sd_p16_percent``, ``_p50_``, ``_p84_``) and ``campaigns``, ``campaigns_failed``."""
    out = {}
    probabilities = np.array(list(quantiles.values()))
    for basis in ("analytic", "montecarlo"):
        if not agb.has(basis) or (basis == "analytic" and not agb.has_sampled_terms):
            continue
        out[f"{basis}.mean_standard_error_percent"] = 100 * agb.standard_error("mean", basis)
        out[f"{basis}.rmse_standard_error_percent"] = 100 * agb.standard_error("rmse", basis)
        errors = agb.standard_error("quantile", basis, probabilities)
        for k, label in enumerate(quantiles):
            out[f"{basis}.{label}_standard_error_percent"] = 100 * np.asarray(errors)[..., k]
    for c in agb.contributions:
        u = c.uncertainty
        if u is None:
            continue
        key = f"contribution.{c.name}"
        out[f"{key}.sigma_sd_standard_error_percent"] = 100 * u.relative_sd_standard_error
        for name, value in u.spread.items():
            out[f"{key}.sigma_sd_{name}_percent"] = 100 * value
        out[f"{key}.campaigns"] = plain(np.asarray(u.campaigns, dtype=float))
        out[f"{key}.campaigns_failed"] = plain(np.asarray(u.failed, dtype=float))
    return out


def relative_moments(relative_samples) -> tuple:
    """(mean, its SE, SD, its SE) of Monte Carlo relative sigma errors ((M, N) or (M,)), cluster-robust over the
    M realisations (``e2esim.distortion.validation.sample_moments``; SE of the SD by the delta method)."""
    m = sample_moments(relative_samples)
    sd = float(np.sqrt(max(m["variance"], 0.0)))
    return m["mean"], m["mean_se"], sd, (m["variance_se"] / (2 * sd) if sd > 0 else 0.0)
