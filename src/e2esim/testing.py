"""Conformance check for module classes, ours and third parties' (model: scikit-learn's
``parametrize_with_checks``).

``check_module(cls, config)`` builds the module from ``config`` and checks that: the declaration is
well formed (kind, type name, summary, unique parameter names with docs); the configuration round-trips
(``cls(**m.config) == m``) and pickles; ``forward`` on a representative case state fills what the module
says it provides, does not touch what it does not, and is deterministic for a given random generator.
Run it in a plug-in's own tests::

    from e2esim.testing import check_module
    def test_my_instrument():
        check_module(MyInstrument, {"calibration_grade": "nominal"})
"""

from __future__ import annotations

import dataclasses
import pickle

import numpy as np

from e2esim.chain import CaseState, SimulationSettings
from e2esim.module import KINDS, Module
from e2esim.params import Param, ParamGroup, iter_params

_SMALL = SimulationSettings(mode="both", seed=1, looks=500, realisations=400, noise_realisations=1)
"""Monte Carlo sizes small enough for a quick check."""

_DEFAULT_CHAIN = {
    "orbit": ("biomass_orbit", {"site": {"name": "boreal", "lat_deg": 60.0, "lon_deg": 92.0}, "swath_samples": 2,
                                "acquisitions": {"start": "2026-01-01", "end": "2026-12-31", "step_days": 60}}),
    "scene": ("table1_forest", {"forest": "boreal_200"}),
    "instrument": ("biomass", {}),
    "ionosphere": ("gaussian_faraday", {"mean_deg": 60.0, "sd_deg": 5.0}),
    "propagation": ("hv_backscatter_error", {}),
    "retrieval": ("power_law", {}),
}
"""Built-in modules that produce the state a module of a later kind expects."""


def reference_state(before_kind: str, settings: SimulationSettings = _SMALL, seed: int = 0,
                    including: bool = False) -> CaseState:
    """A case state as the built-in default chain leaves it just before a module of ``before_kind`` (or just
    after the default module of that kind, with ``including``: for modules stacked after it)."""
    from e2esim import registry

    state = CaseState(index=0, inputs={}, settings=settings, rng=np.random.default_rng(seed))
    for kind in KINDS[: KINDS.index(before_kind) + int(including)]:
        if kind in _DEFAULT_CHAIN:
            type_name, config = _DEFAULT_CHAIN[kind]
            state = registry.lookup(kind, type_name)(**config).forward(state)
    return state


def check_declaration(cls) -> None:
    assert isinstance(cls, type) and issubclass(cls, Module), f"{cls} is not a Module subclass"
    assert cls.kind in KINDS, f"{cls.__name__}.kind {cls.kind!r} is not one of {KINDS}"
    assert cls.type_name and cls.type_name.isidentifier(), f"{cls.__name__}.type_name must be an identifier"
    assert cls.summary, f"{cls.__name__}.summary is empty"
    names = [name for name, _ in iter_params(cls.params)]
    assert len(names) == len(set(names)), f"{cls.__name__}: duplicate parameter names"
    for p in cls.params:
        assert isinstance(p, (Param, ParamGroup)), f"{cls.__name__}: {p!r} is not a Param"
    for name, p in iter_params(cls.params):
        assert p.doc, f"{cls.__name__}.{name} has no doc"
        assert not name.endswith(("_deg", "_db", "_mhz", "_km", "_percent")) or p.unit, (
            f"{cls.__name__}.{name}: the unit in the name must be declared")


def check_module(cls, config: dict | None = None, state: CaseState | None = None) -> Module:
    """Run every conformance check on ``cls`` built with ``config``; return the built module."""
    check_declaration(cls)
    module = cls(**(config or {}))
    rebuilt = cls(**module.config)
    assert rebuilt == module, f"{cls.__name__}: configuration does not round-trip"
    assert pickle.loads(pickle.dumps(module)) == module, f"{cls.__name__}: does not survive pickling"
    assert repr(module).startswith(cls.__name__)

    if state is None:
        state = reference_state(cls.kind)
        if any(getattr(state, f, None) is None for f in cls.requires):  # stacked after the default module
            state = reference_state(cls.kind, including=True)
    missing = [f for f in cls.requires if getattr(state, f, None) is None]
    assert not missing, f"{cls.__name__} requires {missing}, which the reference state lacks"
    before = dataclasses.replace(state, rng=None)
    out1 = module.forward(dataclasses.replace(state, rng=np.random.default_rng(123)))
    out2 = pickle.loads(pickle.dumps(module)).forward(dataclasses.replace(state, rng=np.random.default_rng(123)))
    assert isinstance(out1, CaseState), f"{cls.__name__}.forward must return a CaseState"
    for f in cls.provides:
        assert getattr(out1, f) is not None, f"{cls.__name__} says it provides {f!r} but left it empty"
    changed = {f.name for f in dataclasses.fields(CaseState)
               if f.name != "rng" and getattr(out1, f.name) is not getattr(before, f.name)}
    allowed = set(cls.provides) | ({"verdicts"} if cls.kind == "requirement" else set())
    allowed |= {"backscatter"} if cls.kind == "propagation" else set()
    allowed |= {"system", "faraday", "calibration"} if cls.kind == "calibration" else set()
    assert changed <= allowed, f"{cls.__name__}.forward changed {sorted(changed - allowed)} it does not provide"
    assert _fingerprint(out1) == _fingerprint(out2), f"{cls.__name__}.forward is not deterministic for a given rng"
    return module


def _fingerprint(state: CaseState):
    from e2esim.runner.records import case_scalars

    return sorted((k, v) for k, v in case_scalars(dataclasses.replace(state, rng=None)).items() if v == v)
