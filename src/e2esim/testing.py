"""Conformance check for module classes, ours and third parties' (model: scikit-learn's
``parametrize_with_checks``).

``check_module(cls, config)`` builds the module from ``config`` and checks that: the declaration is
well formed (kind, type name, summary, unique parameter names with docs, units in the names, unique SI
names); the configuration round-trips (``cls(**m.config) == m``, with the same SI values after ``derive``)
and pickles; and what the module does on a representative case made by e2esim's default chain:

* a ``Stage``: ``forward`` returns exactly the products it declares, each of its declared type, and is
  deterministic for a given random generator (compared through the products' output scalars);
* a ``Requirement``: ``evaluate`` returns a ``RequirementVerdict``, deterministically;
* block invariance (stages and requirements, in the spirit of scikit-learn's subset-invariance check): where the
  batched engine would use a fast path (a ``forward`` that takes blocks, a requirement's ``batched`` evaluation; see
  ``e2esim.module.batched_run``), every case of a block of varied cases (``BLOCK_VARIANTS``) gets bit for bit the
  output scalars and verdicts it gets alone;
* an error term: the wrapped model has its sources and is deterministic; and block invariance, its effects in a
  block equal its per-case effects (``check_error_term_blocks``: the default chain's propagation with the term, its
  block path against each case alone);
* a ``CalibrationModule``: its steps are ``CalibrationStep`` objects and the strategy made of it is
  deterministic;
* a Faraday-rotation estimator: its predicted SD is a positive number.

Run it in a plug-in's own tests::

    from e2esim.testing import check_module
    def test_my_instrument():
        check_module(MyInstrument, {"calibration_grade": "nominal"})
"""

from __future__ import annotations

import math
import pickle

import numpy as np

from e2esim.case import Case, Products
from e2esim.error_terms.stage import ErrorTermStack
from e2esim.errors import Location
from e2esim.module import Module, Stage
from e2esim.params import Constraint, Param, ParamGroup, iter_params
from e2esim.settings import SimulationSettings

SMALL = SimulationSettings(mode="both", seed=1, looks=500, realisations=400, noise_realisations=1)
"""Monte Carlo sizes small enough for a quick check."""

DEFAULT_CHAIN = (
    ("orbit", "biomass_orbit", {"site": {"name": "boreal", "lat_deg": 60.0, "lon_deg": 92.0}, "swath_samples": 2,
                                "acquisitions": {"start": "2026-01-01", "end": "2026-12-31", "step_days": 60}}),
    ("scene", "table1_forest", {"forest": "boreal_200"}),
    ("instrument", "biomass", {}),
    ("ionosphere", "gaussian_faraday", {"mean_deg": 60.0, "sd_deg": 5.0}),
    ("propagation", "hv_backscatter_error", {}),
    ("retrieval", "power_law", {}),
)
"""Built-in modules whose chain makes the products a module under test needs."""


ANALYTIC = SimulationSettings(mode="analytic", seed=1, looks=500, realisations=400, noise_realisations=1)
"""Settings under which the batched engine takes its fast paths (they decline Monte Carlo cases)."""

BLOCK_VARIANTS = (
    {},
    {"scene": {"forest": "tropical_338"}, "ionosphere": {"mean_deg": 5.0, "sd_deg": 0.0}},
    {"scene": {"forest": "boreal_50"}, "instrument": {"crosstalk": {"level_db": -25.0}, "nesz_db": -30.0}},
    {"scene": {"forest": "tropical_341"}, "instrument": {"channel_imbalance": {"level_db": None}},
     "ionosphere": {"mean_deg": 30.0, "sd_deg": 20.0}},
)
"""Changes to ``DEFAULT_CHAIN``'s configurations that make the cases of the block invariance check differ."""


def _chain_modules(variant: dict | None = None) -> list:
    from e2esim import registry

    variant = variant or {}
    return [registry.lookup(kind, name)(**_merged(config, variant.get(kind, {})))
            for kind, name, config in DEFAULT_CHAIN]


def _merged(config: dict, change: dict) -> dict:
    out = dict(config)
    for key, value in change.items():
        out[key] = _merged(out.get(key, {}), value) if isinstance(value, dict) else value
    return out


def reference_case(needs=(), uses=(), settings: SimulationSettings = SMALL, seed: int = 0,
                   variant: dict | None = None) -> Case:
    """A case holding the products ``needs`` names (and those of ``uses`` the default chain makes), made by
    the default chain (``DEFAULT_CHAIN``, no calibration; ``variant``: changes to its configurations, as in
    ``BLOCK_VARIANTS``) and stopped as soon as it has them."""
    from e2esim.runner.chain import assemble
    from e2esim.runner.stage_products import checked_products

    chain = assemble(_chain_modules(variant), Location("reference chain"))
    makeable = {p.name for stage in chain for p in stage.provides}
    wanted = set(needs) | (set(uses) & makeable)
    case = Case(index=0, inputs={}, settings=settings, rng=np.random.default_rng(seed))
    for stage in chain:
        if wanted <= set(case.products):
            break
        case = case.adding(checked_products(stage, stage.forward(case)))
    missing = wanted - set(case.products)
    assert not missing, f"the default chain cannot make {sorted(missing)}; give check_module a case"
    return case


def reference_block(needs=(), uses=(), case: Case | None = None, variants=BLOCK_VARIANTS,
                    settings: SimulationSettings = ANALYTIC):
    """A block of ``len(variants)`` cases of the default chain (``reference_case`` of each variant) holding what
    ``needs`` names, made the way the batched engine makes it: each stage through its fast path where it has
    one, else case by case (a ``Factor``); and the same cases one by one. Products of ``case`` that the default
    chain does not make are added to every case. Returns ``(block, cases)``."""
    from e2esim.block import Block, Factor
    from e2esim.module import batched_run
    from e2esim.runner.chain import assemble

    chains = [assemble(_chain_modules(v), Location("reference chain")) for v in variants]
    n = len(variants)
    makeable = {p.name for stage in chains[0] for p in stage.provides}
    wanted = set(needs) | (set(uses) & makeable)
    cases = [Case(index=k, inputs={}, settings=settings, rng=np.random.default_rng(k)) for k in range(n)]
    products: dict = {}
    for stages in zip(*chains):
        if wanted <= set(products):
            break
        fast = batched_run(stages[0]) if all(s == stages[0] for s in stages) else None
        new = fast(Block(np.arange(n), settings, dict(products), cases[0].services)) if fast else None
        if new is None:
            made = [stage.forward(c) for stage, c in zip(stages, cases)]
            new = {name: Factor([m[name] for m in made], np.arange(n)) for name in made[0]}
        products.update(new)
        cases = [c.adding({name: value.item(k) for name, value in new.items()}) for k, c in enumerate(cases)]
    extra = {} if case is None else {name: case[name] for name in case.products if name not in products}
    products.update({name: Factor.single(value, n) for name, value in extra.items()})
    cases = [c.adding(extra) for c in cases]
    missing = wanted - set(products)
    assert not missing, f"the default chain cannot make {sorted(missing)}; give check_module a case"
    return Block(np.arange(n), settings, products, cases[0].services), cases


def check_block_invariance(stage, case: Case | None = None, variants=BLOCK_VARIANTS) -> bool:
    """Assert that ``stage``'s fast path (``e2esim.module.batched_run``) gives every case of a block of varied cases
    (``reference_block``) bit for bit the output scalars, and verdicts, that ``forward`` gives the case alone.
    ``stage`` is a ``Stage``, or a requirement set (``e2esim.requirements.stage.RequirementSet``). Returns whether a
    fast path was checked (False: the stage has none, or it declined these cases)."""
    from e2esim.case import Products
    from e2esim.module import batched_run
    from e2esim.runner.columns import scalar_columns
    from e2esim.runner.records import case_scalars

    fast = batched_run(stage)
    if fast is None:
        return False
    block, cases = reference_block(stage.needs, stage.uses, case, variants)
    got = fast(block)
    if got is None:
        return False
    declared = {p.name: p for p in stage.provides}
    name = getattr(stage, "identity", type(stage).__name__)
    columns = scalar_columns(got, len(cases), declared)
    for k, one in enumerate(cases):
        alone = stage.forward(one)
        assert set(got) == set(alone), f"{name}: the fast path gives {sorted(got)}, forward {sorted(alone)}"
        expected = case_scalars(Products(alone), declared)
        in_block = {key: float(column.values[k]) for key, column in columns.items()
                    if column.present is None or column.present[k]}
        differ = sorted(key for key in expected.keys() | in_block.keys()
                        if not _identical(expected.get(key), in_block.get(key)))
        shown = differ[:3]
        assert not differ, (f"{name}: case {k} of a block differs from the case run alone in {differ[:5]} "
                            f"(block {[in_block.get(d) for d in shown]}, alone {[expected.get(d) for d in shown]})")
        if "verdicts" in alone:
            for v, w in zip(got["verdicts"].item(k), alone["verdicts"]):
                assert _same_verdict(v, w), f"{name}: verdict {w.name!r} of case {k} differs in a block:\n{v}\n{w}"
    return True


def check_error_term_blocks(term, case: Case | None = None, variants=BLOCK_VARIANTS) -> bool:
    """Assert that the error term ``term``'s effects in a block equal its per-case effects: the default chain's
    propagation (``DEFAULT_CHAIN``) with ``term`` as its one error term (``e2esim.error_terms.stage.ErrorTermStack``)
    gives every case of a block of varied cases, through the block path (``ErrorTerm.wrap_block``), bit for bit
    the output scalars that the case alone gets (``ErrorTerm.wrap``): ``check_block_invariance`` of that stage.
    Returns whether the block path was checked (False: the term runs case by case, ``effects_take_blocks``)."""
    propagation = next(module for module in _chain_modules() if module.kind == "propagation")
    return check_block_invariance(ErrorTermStack(propagation, [term]), case, variants)


def _identical(a, b) -> bool:
    if a is None or b is None:
        return a is b
    return a == b or (a != a and b != b)


def _same_verdict(v, w) -> bool:
    plain = ("name", "passed", "unit", "basis", "dominant", "notes", "value", "limit", "margin", "applicable",
             "reason", "coverage", "coverage_text")
    return (all(_identical(getattr(v, f), getattr(w, f)) if isinstance(getattr(w, f), float)
                else getattr(v, f) == getattr(w, f) for f in plain)
            and list(v.details) == list(w.details) and all(_identical(v.details[k], w.details[k]) for k in w.details)
            and list(v.curves) == list(w.curves)
            and all(np.array_equal(v.curves[k], w.curves[k], equal_nan=True) for k in w.curves))


def check_declaration(cls) -> None:
    assert isinstance(cls, type) and issubclass(cls, Module), f"{cls} is not a Module subclass"
    assert isinstance(cls.kind, str) and cls.kind.isidentifier(), f"{cls.__name__}.kind {cls.kind!r} is not a name"
    assert cls.type_name and cls.type_name.isidentifier(), f"{cls.__name__}.type_name must be an identifier"
    assert cls.summary, f"{cls.__name__}.summary is empty"
    names = [name for name, _ in iter_params(cls.params)]
    assert len(names) == len(set(names)), f"{cls.__name__}: duplicate parameter names"
    si_names = [name.rpartition(".")[0] + "." + p.si_name for name, p in iter_params(cls.params)]
    assert len(si_names) == len(set(si_names)), f"{cls.__name__}: two parameters share an SI name"
    for p in cls.params:
        assert isinstance(p, (Param, ParamGroup, Constraint)), f"{cls.__name__}: {p!r} is not a Param"
    for name, p in iter_params(cls.params):
        assert p.doc, f"{cls.__name__}.{name} has no doc"
        assert not name.endswith(("_deg", "_db", "_mhz", "_km", "_percent")) or p.unit, (
            f"{cls.__name__}.{name}: the unit in the name must be declared")
    if issubclass(cls, Stage):
        for product in cls.provides:
            assert hasattr(product, "name") and hasattr(product, "type"), (
                f"{cls.__name__}.provides must hold Product declarations (e2esim.products), got {product!r}")


def check_module(cls, config: dict | None = None, case: Case | None = None) -> Module:
    """Run every conformance check on ``cls`` built with ``config``; return the built module."""
    check_declaration(cls)
    module = cls(**(config or {}))
    rebuilt = cls(**module.config)
    assert rebuilt == module, f"{cls.__name__}: configuration does not round-trip"
    assert _same(rebuilt.si, module.si), f"{cls.__name__}: derive() gives other SI values for the same configuration"
    copy = pickle.loads(pickle.dumps(module))
    assert copy == module, f"{cls.__name__}: does not survive pickling"
    assert repr(module).startswith(cls.__name__)

    from e2esim.calibration.modules import CalibrationModule
    from e2esim.error_terms.modules import ErrorTerm
    from e2esim.faraday.estimator_modules import FaradayEstimatorModule
    from e2esim.requirements.base import Requirement

    if isinstance(module, Stage):
        _check_stage(module, copy, case)
        check_block_invariance(module, case)
    elif isinstance(module, Requirement):
        _check_requirement(module, copy, case)
        from e2esim.requirements.stage import RequirementSet

        check_block_invariance(RequirementSet([module], Location("check")), case)
    elif isinstance(module, CalibrationModule):
        _check_calibration(module, copy, case)
    elif isinstance(module, ErrorTerm):
        _check_error_term(module, copy, case)
        check_error_term_blocks(module, case)
    elif isinstance(module, FaradayEstimatorModule):
        case = case or reference_case(("scene.covariance", "system", "faraday.geophysical", "instrument"))
        system = case["system"]
        sd = module.predicted_sd(case["scene.covariance"], system.noise_power, case["faraday.geophysical"], 10_000,
                                 case["instrument"])
        assert math.isfinite(sd) and sd > 0, f"{cls.__name__}.predicted_sd gives {sd!r}"
    return module


def _with_rng(case: Case, seed: int) -> Case:
    from dataclasses import replace

    return replace(case, rng=np.random.default_rng(seed))


def _check_stage(module, copy, case) -> None:
    from e2esim.runner.records import case_scalars
    from e2esim.runner.stage_products import checked_products

    name = type(module).__name__
    case = case or reference_case(module.needs, module.uses)
    missing = [n for n in module.needs if n not in case]
    assert not missing, f"{name} needs {missing}, which the reference case lacks"
    try:
        out1 = checked_products(module, module.forward(_with_rng(case, 123)))
        out2 = checked_products(copy, copy.forward(_with_rng(case, 123)))
    except TypeError as exc:  # what the runner would refuse
        raise AssertionError(str(exc)) from exc
    declared = {p.name: p for p in module.provides}
    assert case_scalars(Products(out1), declared).keys() == case_scalars(Products(out2), declared).keys()
    assert _fingerprint(case_scalars(Products(out1), declared)) == _fingerprint(
        case_scalars(Products(out2), declared)
    ), f"{name}.forward is not deterministic for a given rng"


def _check_requirement(module, copy, case) -> None:
    from e2esim.requirements.verdict import RequirementVerdict

    name = type(module).__name__
    case = case or reference_case(module.needs, module.uses)
    v1 = module.evaluate(_with_rng(case, 123))
    v2 = copy.evaluate(_with_rng(case, 123))
    assert isinstance(v1, RequirementVerdict), f"{name}.evaluate must return a RequirementVerdict"
    assert _fingerprint(v1.details) == _fingerprint(v2.details) and v1.value == v2.value, (
        f"{name}.evaluate is not deterministic")


def _check_calibration(module, copy, case) -> None:
    from e2esim.calibration.stage import CalibrationStrategy
    from e2esim.calibration.steps import CalibrationStep
    from e2esim.runner.records import case_scalars

    name = type(module).__name__
    case = case or reference_case(module.needs, module.uses)
    steps = module.steps(_with_rng(case, 123))
    assert all(isinstance(step, CalibrationStep) for _, step in steps), f"{name}.steps must give CalibrationSteps"
    runs = [CalibrationStrategy([m], Location("check")).forward(_with_rng(case, 123)) for m in (module, copy)]
    assert _fingerprint(case_scalars(Products(runs[0]))) == _fingerprint(case_scalars(Products(runs[1]))), (
        f"{name}: the calibration strategy is not deterministic for a given rng")


def _check_error_term(module, copy, case) -> None:
    name = type(module).__name__
    case = case or reference_case(("backscatter.error", *module.needs), module.uses)
    models = [m.wrap(case["backscatter.error"], _with_rng(case, 123)) for m in (module, copy)]
    for source in module.sources:
        assert source in models[0].sources and source in models[0].levels, (
            f"{name}: the wrapped model lacks the source {source!r}")
    assert _fingerprint(models[0].scalars()) == _fingerprint(models[1].scalars()), (
        f"{name}.wrap is not deterministic for a given rng")


def _fingerprint(values: dict):
    return sorted((k, v) for k, v in values.items() if isinstance(v, float) and v == v)


def _same(a, b) -> bool:
    if hasattr(a, "keys") and hasattr(b, "keys"):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, Module) or isinstance(b, Module):
        return a == b
    return bool(np.array_equal(np.asarray(a, dtype=object), np.asarray(b, dtype=object)))
