"""The open chain: stages ordered by the products they need and provide, products never overwritten and
checked for their type, missing products caught before a run, and verdicts that say when the error model
cannot give margins or attribution."""

import dataclasses
import json

import numpy as np
import pytest

from e2esim import products as P
from e2esim.case import Case, Products
from e2esim.cli import main
from e2esim.errors import ConfigError, Location
from e2esim.module import Stage
from e2esim.products import Product
from e2esim.runner.chain import assemble
from e2esim.runner.run import checked_products, run_case
from e2esim.runner.scenario import Scenario
from e2esim.scene.covariance import ScatteringCovariance
from e2esim.settings import SimulationSettings

BASE = {
    "scene": {"type": "table1_forest", "forest": "boreal_200"},
    "instrument": {"type": "biomass"},
    "ionosphere": {"type": "gaussian_faraday", "mean_deg": 60.0, "sd_deg": 5.0},
    "requirements": [{"type": "agb_error_bound", "level_margins": True, "tradeoff_curve": True, "curve_points": 5}],
    "simulation": {"mode": "both", "seed": 5, "looks": 10_000, "realisations": 500},
}

EXTRA = Product("test.doubled_scene", ScatteringCovariance, "the scene's covariance doubled (a test product)")


class Doubler(Stage):
    """A stage of a kind e2esim does not know, between the scene and a stage that needs its product."""

    kind = "doubling"
    type_name = "double"
    summary = "doubles the scene"
    needs = ("scene.covariance",)
    provides = (EXTRA,)

    def forward(self, case):
        scene = case["scene.covariance"]
        return {"test.doubled_scene": ScatteringCovariance(2 * scene.matrix, agb_t_ha=scene.agb_t_ha)}


class NeedsDoubled(Stage):
    kind = "checking"
    type_name = "needs_doubled"
    summary = "reads the doubled scene"
    needs = ("test.doubled_scene", "agb.error")
    provides = (Product("test.ratio", float, "doubled over original sigma_hv"),)

    def forward(self, case):
        return {"test.ratio": case["test.doubled_scene"].sigma_hv / case["scene.covariance"].sigma_hv}


def _modules(**changes):
    return Scenario({**BASE, **changes}, "<test>").resolve().cases[0].modules


def test_the_chain_follows_the_products_wherever_the_sections_are():
    modules = _modules()
    chain = assemble([NeedsDoubled(), *modules, Doubler()], Location("<test>"))  # listed in the wrong order
    kinds = [stage.kind for stage in chain]
    assert kinds.index("doubling") < kinds.index("checking")
    assert kinds.index("scene") < kinds.index("doubling")
    assert kinds.index("retrieval") < kinds.index("checking")
    assert kinds[-1] in ("checking", "requirement")
    provided = [p.name for stage in chain for p in stage.provides]
    assert len(provided) == len(set(provided))  # every product made once


def test_a_missing_product_names_the_stage_and_who_could_provide_it():
    with pytest.raises(ConfigError, match=r"checking type 'needs_doubled' needs the product 'test.doubled_scene', "
                                          r"which no stage of this chain provides.*no registered module provides it"):
        assemble([NeedsDoubled(), *_modules()], Location("<test>"))


def test_validate_reports_a_missing_product_with_exit_status_2(tmp_path, capsys):
    path = tmp_path / "s.yaml"
    path.write_text("scene: {type: table1_forest}\ninstrument: {type: biomass}\n"
                    "ionosphere: {type: iri_climatology, method: thin_shell}\n")
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}:3: ionosphere: ionosphere type 'iri_climatology' needs the product 'geometry'" in err
    assert ("modules that provide it: orbit.biomass_orbit, orbit.biomass_orbit_file, orbit.orbit_file, "
            "orbit.sun_synchronous") in err


def test_products_are_never_replaced_and_are_type_checked():
    case = Case(0, {}, SimulationSettings(), np.random.default_rng(0))
    case = case.adding({"x": 1.0})
    with pytest.raises(ValueError, match="products x are already in the case and cannot be replaced"):
        case.adding({"x": 2.0})
    with pytest.raises(TypeError, match=r"scene type 'broken' returned a list for product 'scene.covariance', which "
                                        r"must be a ScatteringCovariance"):
        checked_products(_Named("scene", "broken", (P.SCENE,)), {"scene.covariance": [1.0]})
    with pytest.raises(TypeError, match=r"returned scene.covariance, extra; it declares scene.covariance"):
        checked_products(_Named("scene", "broken", (P.SCENE,)), {"scene.covariance": None, "extra": 1})
    assert list(Products({"a": 1}).adding({"b": 2})) == ["a", "b"]


@dataclasses.dataclass
class _Named:
    kind: str
    type_name: str
    provides: tuple

    @property
    def identity(self):
        return f"{self.kind} type {self.type_name!r}"


def test_calibration_adds_residual_products_beside_the_raw_ones():
    spec = Scenario({**BASE, "calibration": [{"type": "transponder_calibration"}, {"type": "faraday_correction"}]},
                    "<test>").resolve().cases[0]
    case = run_case(spec)
    names = list(case.products)
    assert names.index("system") < names.index("system.residual")
    assert case.get("system").crosstalk_level > 2 * case.get("system.residual").crosstalk_level  # 30 dB SCR
    assert case.get("faraday.geophysical").mean_rad == pytest.approx(np.radians(60.0))
    assert case.get("faraday.residual").mean_rad == 0.0  # absorbed in the residual crosstalk


def test_verdicts_say_why_there_are_no_margins_or_attribution(tmp_path):
    spec = Scenario({**BASE, "simulation": {**BASE["simulation"], "mode": "montecarlo"}}, "<test>").resolve()
    case = run_case(spec.cases[0])
    verdict = case.verdicts[0]
    assert verdict.basis == "montecarlo" and not any(k.endswith(".limit_db") for k in verdict.details)
    reason = "the analytic moments are not computed in simulation mode 'montecarlo'"
    assert verdict.notes == (f"no level margins or trade-off curve: {reason}",
                             f"no attribution to error sources: {reason}")
    out = tmp_path / "run"
    path = tmp_path / "mc.yaml"
    import yaml

    path.write_text(yaml.safe_dump({**BASE, "simulation": {**BASE["simulation"], "mode": "montecarlo"}}))
    assert main(["run", str(path), "-o", str(out), "--no-progress"]) == 0
    assert f"no level margins or trade-off curve: {reason}" in (out / "report.md").read_text()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["cases"][0]["requirements"][0]["notes"][1] == f"no attribution to error sources: {reason}"


def test_the_error_model_answers_for_every_later_stage():
    """Retrieval, attribution and margins read the same error model; removing a source changes exactly it."""
    case = run_case(Scenario(BASE, "<test>").resolve().cases[0])
    model = case.get("backscatter.error")
    assert set(model.levels) == {"crosstalk", "channel_imbalance", "nesz"}
    no_ci = model.without("channel_imbalance")
    # the variant's levels (a case alone's as a block's: its products stay the model's, issue 27 item 2)
    assert no_ci.levels["channel_imbalance"] == 0.0 and no_ci.levels["crosstalk"] == model.levels["crosstalk"]
    assert no_ci.levels["nesz"] == model.levels["nesz"] and no_ci.montecarlo is None
    assert model.without("gain") is model  # no gain error: nothing to remove
    parts = model.contributions()
    m = model.current()
    assert sum(c.mean for c in parts.values()) == pytest.approx(float(m.mean), rel=1e-12)
    assert sum(c.variance for c in parts.values()) == pytest.approx(float(m.variance), rel=1e-12)
    # the margin search evaluates the same model: at the crosstalk limit the verdict's bound is just met
    details = case.verdicts[0].details
    limit = 10 ** (details["crosstalk.limit_db"] / 10) * 2 / 9  # 3-sigma label to variance
    from scipy import stats

    p, sigma = 2.2, model.value
    f_sigma = (1.2 ** (1 / p) - 1) * sigma
    at_limit = model.moments(crosstalk=limit)
    assert float(at_limit.mean + stats.norm.ppf(0.99865) * at_limit.sd) == pytest.approx(f_sigma, rel=1e-6)
