"""The error-term list (issue 27, Build 2): the shipped terms' equations against their Monte Carlo, the wrapped model's
answers (levels, sources, without, contributions), and scenarios whose terms compose, in both engines."""

import math

import numpy as np
import pytest

from e2esim import api
from e2esim.error_model import (
    Contribution,
    ErrorModel,
    JointContribution,
    JointMoments,
    Moments,
    MultiChannelErrorModel,
)
from e2esim.error_terms.effects import AddedPower, ExtraVariance, GammaFactor, LogNormalGain
from e2esim.error_terms.modules import AddedNoise, ExtraRelativeVariance, GainError
from e2esim.error_terms.wrapped import WrappedErrorModel, WrappedMultiChannelErrorModel, innermost, wrapped
from e2esim.errors import ConfigError
from e2esim.testing import check_module


class GaussianModel(ErrorModel):
    """A model whose errors are exactly N(mean, variance): the wrapped model of the statistical tests."""

    def __init__(self, value, mean, variance, samples=None):
        self._value, self.mean, self.variance, self._samples = value, mean, variance, samples

    value = property(lambda self: self._value)
    levels = property(lambda self: {})
    sources = property(lambda self: ("base",))

    def moments(self, **levels):
        return Moments(np.asarray(self.mean), np.asarray(self.variance))

    def without(self, source):
        return self

    def contributions(self):
        return {"base": Contribution(self.mean, self.variance)}

    def relative_samples(self):
        return self._samples


class GaussianJoint(MultiChannelErrorModel):
    """Three channels with jointly Gaussian errors of given mean vector and covariance."""

    def __init__(self, values, mean, cov, samples=None):
        self._values, self.mean, self.cov, self._samples = np.asarray(values), np.asarray(mean), np.asarray(cov), \
            samples

    values = property(lambda self: self._values)
    levels = property(lambda self: {})
    sources = property(lambda self: ("base",))

    def joint_moments(self, **levels):
        return JointMoments(self.channels, self.mean, self.cov)

    def joint_contributions(self):
        return {"base": JointContribution(self.mean, self.cov)}

    def without(self, source):
        return self

    def joint_relative_samples(self):
        return self._samples


EFFECTS = {
    "gamma factor": GammaFactor("scint", 0.02),
    "log-normal gain": LogNormalGain("gain", (0.5 * math.log(10) / 10) ** 2, offset_db=0.3),
    "added power": AddedPower("noise", 0.05, looks=50),
    "added power, subtracted": AddedPower("noise", 0.05, looks=50, subtracted=True),
    "extra variance": ExtraVariance("extra", 0.03**2),
}


def _z_mean(x, mean):
    return (x.mean() - mean) / (x.std(ddof=1) / math.sqrt(x.size))


def _z_var(x, variance):
    d = x - x.mean()
    return (x.var(ddof=1) - variance) / math.sqrt((np.mean(d**4) - np.mean(d**2) ** 2) / x.size)


@pytest.mark.parametrize("name", list(EFFECTS))
def test_an_error_term_s_moments_agree_with_its_monte_carlo(name, rng):
    """Mean and variance of e' (analytic, the equations of e2esim.error_terms.effects) against the sample moments of
    e' made from Gaussian base errors and the term's own draws: z-tests, any seed."""
    sigma, m, v = 0.8, 0.02, 0.05**2
    x = rng.normal(m / sigma, math.sqrt(v) / sigma, (400, 100))
    base = GaussianModel(sigma, m, v, x)
    effect = EFFECTS[name].draw(rng, (*x.shape, 1))
    model = wrapped(base, effect)
    e = model.relative_samples().ravel() * sigma
    current = model.current()
    z = (_z_mean(e, float(current.mean)), _z_var(e, float(current.variance)))
    assert abs(z[0]) < 4.5 and abs(z[1]) < 4.5, (name, z)


@pytest.mark.parametrize("name", list(EFFECTS))
def test_an_error_term_s_joint_moments_agree_with_its_monte_carlo(name, rng):
    """The covariance of three channels (a gain correlates them, added noise and extra variance do not), analytic
    against the Monte Carlo: every mean and every (co)variance, z-tests, any seed."""
    values = np.array([0.5, 0.1, 0.3])
    mean = np.array([0.01, 0.004, -0.006])
    sd = np.array([0.03, 0.008, 0.02])
    corr = np.array([[1.0, 0.4, 0.7], [0.4, 1.0, 0.3], [0.7, 0.3, 1.0]])
    cov = corr * np.outer(sd, sd)
    e = rng.multivariate_normal(mean, cov, (300, 100))
    base = GaussianJoint(values, mean, cov, e / values)
    model = wrapped(base, EFFECTS[name].draw(rng, e.shape))
    assert isinstance(model, WrappedMultiChannelErrorModel)
    samples = (model.joint_relative_samples() * values).reshape(-1, 3)
    joint = model.current_joint()
    for p in range(3):
        assert abs(_z_mean(samples[:, p], joint.mean[p])) < 4.5, (name, p)
        for q in range(p, 3):
            dp, dq = samples[:, p] - joint.mean[p], samples[:, q] - joint.mean[q]
            prod = dp * dq
            z = (prod.mean() - joint.covariance[p, q]) / (prod.std(ddof=1) / math.sqrt(prod.size))
            assert abs(z) < 4.5, (name, p, q, z)


def test_the_scintillation_factor_gives_the_published_form():
    """Var[e'] = v (1 + V) + (sigma + m)^2 V and E[e'] = m for a factor of mean 1 and variance V (the scintillation
    example's derivation, now GammaFactor's), exactly."""
    sigma, m, v, V = 0.04, 0.002, 1e-5, 2.25e-4
    model = wrapped(GaussianModel(sigma, m, v), GammaFactor("scintillation", V))
    assert float(model.current().mean) == m
    assert float(model.current().variance) == pytest.approx(v * (1 + V) + (sigma + m) ** 2 * V, rel=1e-14)


def test_a_wrapped_model_answers_for_its_source():
    """The term's name is a level (moments at other levels, arrays broadcast), a source (without: the base model's
    moments; an inactive term: the model itself) and a contribution; the contributions add up to the total."""
    base = GaussianModel(1.0, 0.01, 0.002)
    one = wrapped(base, AddedPower("floor", 0.02, looks=10))
    two = wrapped(one, LogNormalGain("drift", 0.01, offset_db=0.1))
    assert isinstance(two, WrappedErrorModel) and innermost(two) is base
    assert two.levels == {"floor": 0.02, "drift": 0.01} and two.sources == ("base", "floor", "drift")
    m = two.moments(floor=np.array([0.0, 0.02]), drift=np.array([[0.0], [0.01]]))
    assert m.mean.shape == (2, 2) and float(m.variance[1, 1]) == pytest.approx(float(two.current().variance))
    without = two.without("floor").current()
    assert float(without.mean) == pytest.approx(float(wrapped(base, LogNormalGain("drift", 0.01, offset_db=0.1))
                                                      .current().mean), rel=1e-14)
    parts = two.contributions()
    assert list(parts) == ["base", "floor", "drift"]
    assert sum(c.mean for c in parts.values()) == pytest.approx(float(two.current().mean), rel=1e-12)
    assert sum(c.variance for c in parts.values()) == pytest.approx(float(two.current().variance), rel=1e-12)
    idle = wrapped(base, ExtraVariance("idle", 0.0))
    assert idle.without("idle") is idle  # no-op: attribution reports 0 for it
    with pytest.raises(ValueError, match="'base' has the name of a level or source"):
        wrapped(base, ExtraVariance("base", 0.01))


SCENARIO = {
    "name": "shipped_terms",
    "scene": {"type": "table1_forest", "forest": "tropical_338"},
    "instrument": {"type": "biomass"},
    "ionosphere": {"type": "gaussian_faraday", "mean_deg": 5.0, "sd_deg": 5.0},
    "error_terms": [{"type": "added_noise", "power_db": -45.0},
                    {"type": "gain_error", "sd_db": 0.02, "offset_db": 0.01},
                    {"type": "extra_variance", "relative_sd_percent": 0.5}],
    "requirements": [{"type": "agb_error_bound", "sources": "systematic", "bound_percent": 20,
                      "confidence_percent": 99.865, "level_margins": True}],
    "simulation": {"seed": 5, "looks": 2000, "realisations": 200},
    "sweep": {"parameters": {"simulation.mode": ["analytic", "montecarlo", "both"]}},
}


def test_shipped_terms_compose_with_attribution_in_both_engines():
    """Three shipped terms on the HV model, every simulation mode: each is attributed and has a margin; the batched
    and per-case engines give the same numbers."""
    runs = [api.run(SCENARIO, engine=engine) for engine in ("batched", "per_case")]
    batched, per_case = runs
    assert batched.scalars.keys() == per_case.scalars.keys()
    for k in batched.scalars:
        np.testing.assert_array_equal(batched.scalars[k], per_case.scalars[k], err_msg=k)
    for k in batched.details[0]:
        np.testing.assert_array_equal(np.asarray(batched.details[0][k]), np.asarray(per_case.details[0][k]),
                                      err_msg=k)
    details = batched.details[0]
    for source in ("added_noise", "gain_error", "extra_variance"):
        contribution = np.asarray(details[f"contribution.{source}_percent"], dtype=float)
        assert np.all(contribution[[0, 2]] > 0), source  # analytic and both; montecarlo has no attribution
        assert np.all(np.isfinite(np.asarray(details[f"{source}.limit_db"], dtype=float)[[0, 2]])), source
    assert "added_noise" in batched.coverage[0, 0] and "extra_variance" in batched.coverage[0, 0]
    # the analytic SD with every term is what the error terms add to the HV model's own
    assert np.all(batched.scalars["analytic.with_error_terms_sd"][[0, 2]] > batched.scalars["analytic.sd"][[0, 2]])


def test_two_terms_with_one_source_name_are_refused():
    scenario = dict(SCENARIO, error_terms=[{"type": "extra_variance", "relative_sd_percent": 1.0},
                                           {"type": "extra_variance", "relative_sd_percent": 0.5}])
    with pytest.raises(ConfigError, match="two error terms have the source 'extra_variance'"):
        api.load_scenario(scenario).resolve()


def test_a_source_name_must_be_a_name():
    scenario = dict(SCENARIO, error_terms=[{"type": "extra_variance", "relative_sd_percent": 1.0,
                                            "source": "Bad name"}])
    with pytest.raises(ConfigError, match=r"error_terms\[0\]\.source: source 'Bad name' is not a name"):
        api.load_scenario(scenario).resolve()


@pytest.mark.parametrize("cls, config", [(AddedNoise, {"power_db": -30.0}), (GainError, {"sd_db": 0.2}),
                                         (ExtraRelativeVariance, {"relative_sd_percent": 1.0})])
def test_shipped_terms_conform(cls, config):
    check_module(cls, config)
