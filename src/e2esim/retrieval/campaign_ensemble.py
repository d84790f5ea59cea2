"""The regression uncertainty of a retrieval model as the expectation over simulated calibration campaigns.

One simulated campaign (n synthetic plots, fitted, its uncertainty estimated by eqs. 3-7 or SIMEX and the
bootstrap, Ahmed et al. 2014) gives one draw of the uncertainty a real campaign would report; its value
moves with the draw by a factor of two or more (38 hectares: the relative SD of the fitted curve at 50 t/ha
ranges over 4-12 % from one campaign to the next). The chain needs the uncertainty of a campaign of this
design, not of one draw of it, so it draws K campaigns (``CalibrationCampaign.campaigns``) and reports

* the expectation over campaigns of each campaign's relative variance at the case's AGB, ``v = mean_k v_k``,
  with its standard error ``sd_k(v_k) / sqrt(K)`` (the variance term the retrieval adds);
* the spread across campaigns: the 16, 50 and 84 % quantiles of the per-campaign relative SD sqrt(v_k),
  the range a single campaign's report would fall in.

The per-campaign variance v_k at AGB M (relative to the true backscatter f(M) of the model, the reference of
every relative sigma error of the chain):

* ``method="delta"``: eq. (4) with the covariance of eq. (6) of the campaign's naive fit, S_y^2 / f(M)^2
  (linear space; in the log space S_y is already relative), plus for ``mode="prediction"`` the residual
  variance (eq. 7);
* ``method="bootstrap"``: SIMEX-corrected coefficients (eqs. 17-19) and the parametric bootstrap around them
  (eqs. 11-14, conditional design, naive refits, as ``e2esim.retrieval.bootstrap``), the robust 16-84 %
  half-range of the bootstrap curves at M squared, plus for ``mode="prediction"`` the eq. (14) error in
  equation.

A campaign whose fit, SIMEX or bootstrap fails is counted (``failed``) and left out. The campaigns are drawn
from their own generator, seeded from the scenario's seed, so every case of a run sees the same campaigns
(the curve over AGB is smooth, and a case's value does not depend on its position in the sweep), and are kept
for the run (``ensemble``), so the cases at other AGB of the same model reuse them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.case_values import plain
from e2esim.errors import PhysicsInputError
from e2esim.memo_keys import value_key
from e2esim.retrieval.simex import simex_batch
from e2esim.retrieval.synthetic import synthetic_field_plots

_STREAM = 0x72656772  # spawn key of the campaigns' generator ("regr"), apart from the cases' (index,) keys
_ROBUST = (0.15865525393145707, 0.8413447460685429)  # +-1 SD of a Gaussian: the robust spread of the curves
SPREAD_QUANTILES = {"p16": 0.15865525393145707, "p50": 0.5, "p84": 0.8413447460685429}
"""Quantiles of the per-campaign relative SD reported as the spread across campaigns."""
_BOOT_CHUNK = 4096  # bootstrap data sets fitted at once (tens of MB of temporaries)


@dataclass(frozen=True)
class RegressionUncertainty:
    """The regression term at one AGB: relative_variance : mean over the campaigns of their relative variance
    (x = e / sigma units). standard_error : its standard error, sd / sqrt(K). spread : {"p16", "p50", "p84"}
    quantiles of the per-campaign relative SD. campaigns : K drawn; failed : how many of them were left out.

    For a block of sweep cases (an ``AGBError`` with a case axis) every field is a (B,) array over the cases
    (``gathered``, ``item``, ``take``); the properties are element-wise, so a case gets the same numbers alone or in
    a block."""

    relative_variance: float
    standard_error: float
    spread: dict
    campaigns: int
    failed: int

    @property
    def relative_sd(self) -> float:
        return plain(np.sqrt(np.maximum(self.relative_variance, 0.0)))

    @property
    def relative_sd_standard_error(self) -> float:
        """SE of sqrt(v) by the delta method, SE(v) / (2 sqrt(v))."""
        sd = np.asarray(self.relative_sd)
        positive = sd > 0
        return plain(np.where(positive, np.asarray(self.standard_error) / (2.0 * np.where(positive, sd, 1.0)), 0.0))

    @classmethod
    def gathered(cls, terms: list, index) -> RegressionUncertainty:
        """The (B,) form of one-case ``terms`` for cases whose term is ``terms[index[i]]``."""
        def column(get, dtype=float):
            return np.asarray([get(t) for t in terms], dtype=dtype)[index]

        return cls(column(lambda t: t.relative_variance), column(lambda t: t.standard_error),
                   {k: column(lambda t, k=k: t.spread[k]) for k in terms[0].spread},
                   column(lambda t: t.campaigns, np.int64), column(lambda t: t.failed, np.int64))

    def item(self, i: int) -> RegressionUncertainty:
        return RegressionUncertainty(float(self.relative_variance[i]), float(self.standard_error[i]),
                                     {k: float(v[i]) for k, v in self.spread.items()}, int(self.campaigns[i]),
                                     int(self.failed[i]))

    def take(self, positions) -> RegressionUncertainty:
        return RegressionUncertainty(self.relative_variance[positions], self.standard_error[positions],
                                     {k: v[positions] for k, v in self.spread.items()}, self.campaigns[positions],
                                     self.failed[positions])

    @staticmethod
    def concatenate(parts: list) -> RegressionUncertainty:
        def joined(get):
            return np.concatenate([np.asarray(get(p)) for p in parts])

        first = parts[0]
        return RegressionUncertainty(joined(lambda p: p.relative_variance), joined(lambda p: p.standard_error),
                                     {k: joined(lambda p, k=k: p.spread[k]) for k in first.spread},
                                     joined(lambda p: p.campaigns), joined(lambda p: p.failed))


@dataclass(frozen=True)
class CampaignEnsemble:
    """K simulated campaigns of one model and design: what each needs to give its variance at any AGB.

    model : the true model. mode, method : of the campaign. fitted : per usable campaign (delta) the
    ``FitResult``; (bootstrap) centre (K', p) SIMEX coefficients, boot (K', B, p) refits and boot_ok (K', B),
    model_error (K',) eq. (14) variances, naive_residual (K',) residual variance of the naive fit (fit space).
    space : fit space. campaigns : K. covariates : keyword arguments of the model (dict).
    """

    model: object
    mode: str
    method: str
    campaigns: int
    space: str
    covariates: tuple
    fitted: tuple = ()
    centre: np.ndarray | None = None
    boot: np.ndarray | None = None
    boot_ok: np.ndarray | None = None
    model_error: np.ndarray | None = None
    naive_residual: np.ndarray | None = None

    @property
    def usable(self) -> int:
        return len(self.fitted) if self.method == "delta" else int(self.centre.shape[0])

    def variances(self, agb: float) -> np.ndarray:
        """(K',) relative variance of each usable campaign at ``agb`` (t/ha)."""
        cov = dict(self.covariates)
        truth = np.atleast_1d(self.model.sigma(agb, **cov))
        f = float(truth[1] if truth.size == 3 else truth[0])  # HV of a multi-channel model
        if self.method == "delta":
            return np.array([_delta_variance(fit, agb, f, cov, self.mode, self.model) for fit in self.fitted])
        m = np.array([float(agb)])
        curves = self.model.evaluate(m, self.boot, **cov)[..., 0]  # (K', B)
        centre = self.model.evaluate(m, self.centre, **cov)[..., 0]  # (K',)
        rel = np.where(self.boot_ok, (curves - centre[:, None]) / f, np.nan)
        lo, hi = np.nanquantile(rel, _ROBUST, axis=1)
        var = ((hi - lo) / 2.0) ** 2
        if self.mode == "prediction":
            var = var + (self.model_error / f**2 if self.space == "linear" else self.naive_residual)
        return var

    def uncertainty(self, agb: float) -> RegressionUncertainty:
        v = self.variances(agb)
        k = v.size
        sd = np.sqrt(np.clip(v, 0.0, None))
        return RegressionUncertainty(
            float(np.mean(v)), float(np.std(v, ddof=1) / np.sqrt(k)) if k > 1 else float("inf"),
            {name: float(np.quantile(sd, q)) for name, q in SPREAD_QUANTILES.items()}, self.campaigns,
            self.campaigns - k)


def campaign_generator(seed: int) -> np.random.Generator:
    """The generator of a run's calibration campaigns (root ``seed`` of the scenario)."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(_STREAM, 0))))


ENSEMBLES_KEPT = 16
"""Ensembles a kernel memo keeps (a sweep over retrieval models draws one per model)."""


def ensemble(model, campaign, seed: int, covariates: dict | None = None, memo=None) -> CampaignEnsemble:
    """The K campaigns of ``campaign`` (a ``CalibrationCampaign``) from ``model``, drawn from ``seed``: the same
    campaigns for every case of a run. memo : the run's ``KernelMemo`` (``case.services.memo``), which keeps them
    for the other cases, found by the values they are drawn from; None: drawn anew."""
    covariates = dict(covariates or {})
    if memo is None:
        return _draw(model, campaign, int(seed), covariates)
    try:  # by value: a repr rounds an array's numbers (two models a little apart would share one ensemble)
        key = ("campaign ensemble", value_key(type(model).__qualname__, model, campaign, int(seed), covariates))
    except TypeError:  # a plug-in model with a field that cannot key a memo: drawn anew
        return _draw(model, campaign, int(seed), covariates)
    return memo.recall(key, lambda: _draw(model, campaign, int(seed), covariates), keep=ENSEMBLES_KEPT)


def _draw(model, campaign, seed, covariates):
    rng = campaign_generator(seed)
    plots = synthetic_field_plots(
        model, campaign.plots, rng, n_datasets=campaign.campaigns, agb_range_t_ha=campaign.agb_range_t_ha,
        agb_distribution="stratified",
        allometric_error=campaign.allometric_error_fraction, backscatter_error=campaign.backscatter_error_fraction,
        model_error=campaign.model_error_fraction,
        incidence_range_rad=None if "incidence_rad" not in covariates else (covariates["incidence_rad"],) * 2)
    fit_cov = {} if plots.incidence_rad is None else {"incidence_rad": plots.incidence_rad}
    multi = np.ndim(model.sigma(1.0, **covariates)) == 1
    if campaign.method == "bootstrap":
        if multi:
            raise PhysicsInputError("regression method 'bootstrap' is implemented for single-channel models; "
                                    "use 'delta'")
        return _bootstrap_ensemble(model, campaign, plots, rng, covariates)
    fitted = []
    for k in range(campaign.campaigns):
        try:
            fit = model.fit(plots.agb[k], plots.sigma[k], **{n: v[k] for n, v in fit_cov.items()})
        except PhysicsInputError:  # an unusable draw (e.g. a plot at AGB 0 for a log fit): counted as failed
            continue
        if fit.converged and np.all(np.isfinite(fit.covariance)):
            fitted.append(fit)
    _check_usable(len(fitted), campaign)
    return CampaignEnsemble(model, campaign.mode, "delta", campaign.campaigns, fitted[0].space,
                            tuple(covariates.items()), tuple(fitted))


def _check_usable(usable: int, campaign) -> None:
    if usable < max(2, campaign.campaigns // 2):
        raise PhysicsInputError(
            f"only {usable} of {campaign.campaigns} simulated calibration campaigns of {campaign.plots} plots could "
            "be fitted; widen agb_range_t_ha, add plots or reduce the measurement errors")


def _delta_variance(fit, agb, f_true, cov, mode, truth) -> float:
    """Eq. (4) (and eq. 7) of one campaign at ``agb``, relative to the true backscatter ``f_true`` (for a
    multi-channel model: HV-equivalent through the true model's HV weight, as every error of the chain)."""
    model = fit.model
    if np.ndim(model.sigma(agb, **cov)) == 1:  # multi-channel: through the joint inversion
        var, pred = multichannel_variance(model, fit.covariance, agb, cov, truth.channel_weights()[1])
    else:
        jac = model.param_jacobian(np.array([agb]), **cov)[0]
        if fit.space == "log":
            var = float(jac @ fit.covariance @ jac) / float(model.sigma(agb, **cov)) ** 2  # S_y in ln sigma
            pred = float(fit.residual_variance)
        else:
            var = float(jac @ fit.covariance @ jac) / f_true**2  # eq. (4)
            pred = float(fit.residual_variance) / f_true**2
    return var + (pred if mode == "prediction" else 0.0)


def _bootstrap_ensemble(model, campaign, plots, rng, covariates):
    """SIMEX (eqs. 17-19) and the conditional parametric bootstrap (eqs. 11-14) of every campaign, batched."""
    w, d, su, sq = plots.agb, plots.sigma, plots.agb_error_sd, plots.sigma_error_sd
    space = model._space(None)
    naive = model.fit_batch(w, d, space=space)
    sx = simex_batch(model, w, d, su, sq, rng, n_sim=campaign.simex_samples, p0=naive.params, space=space)
    good = np.flatnonzero(sx.ok)
    beta = sx.params[good]
    w, d, su, sq = w[good], d[good], su[good], sq[good]
    k, n = w.shape
    p = beta.shape[1]
    fit = model.evaluate(w, beta)
    deriv = np.nan_to_num(model.agb_derivative(w, beta), posinf=0.0, neginf=0.0)
    rms = np.sum((d - fit) ** 2, axis=1) / (n - p)  # eq. (14), denominator n - p (errata A7)
    model_error = np.clip(rms - np.mean(sq**2, axis=1) - np.mean(deriv**2 * su**2, axis=1), 0.0, None)
    naive_residual = naive.ssr[good] / (n - p)
    b = campaign.bootstrap_samples
    boot = np.empty((k, b, p))
    boot_ok = np.zeros((k, b), dtype=bool)
    truth_w = np.repeat(w, b, axis=0)  # conditional design: the field values play the true AGB
    rows_beta = np.repeat(beta, b, axis=0)
    rows_su, rows_sq = np.repeat(su, b, axis=0), np.repeat(sq, b, axis=0)
    rows_eps = np.repeat(np.sqrt(model_error), b)
    flat_boot, flat_ok = boot.reshape(k * b, p), boot_ok.reshape(k * b)
    for start in range(0, k * b, _BOOT_CHUNK):
        rows = slice(start, min(start + _BOOT_CHUNK, k * b))
        x = truth_w[rows]
        w_b = np.clip(x + rows_su[rows] * rng.standard_normal(x.shape), 0.0, None)  # eq. (11)
        y_b = model.evaluate(x, rows_beta[rows]) + rows_eps[rows, None] * rng.standard_normal(x.shape)  # eq. (12)
        d_b = y_b + rows_sq[rows] * rng.standard_normal(x.shape)  # eq. (13)
        refit = model.fit_batch(w_b, d_b, p0=rows_beta[rows], space=space)
        flat_boot[rows], flat_ok[rows] = refit.params, refit.converged
    enough = boot_ok.sum(axis=1) >= p + 1
    _check_usable(int(enough.sum()), campaign)
    return CampaignEnsemble(model, campaign.mode, "bootstrap", campaign.campaigns, space, tuple(covariates.items()),
                            centre=beta[enough], boot=boot[enough], boot_ok=boot_ok[enough],
                            model_error=model_error[enough], naive_residual=naive_residual[enough])


def multichannel_variance(model, coef_cov, agb, cov, hv_weight=None):
    """Var of ln AGB_hat from the coefficients (numerical gradient through the joint inversion) and from
    the error in equation (1 / a^T Sigma_r^-1 a), both as HV-equivalent relative sigma variances: divided by
    the square of ``hv_weight``, the HV weight c_hv of the joint inversion the chain maps its errors through
    (default: the fitted model's own, which a campaign's fit can put near 0)."""
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
    c_hv = model.channel_weights()[1] if hv_weight is None else hv_weight
    a = np.asarray(model.a)
    var_ln = float(grad @ coef_cov @ grad)
    pred_ln = 1.0 / float(a @ np.linalg.solve(model.residual_covariance, a))
    return var_ln / c_hv**2, pred_ln / c_hv**2
