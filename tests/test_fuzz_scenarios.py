"""Fuzzing of scenario files and ``--set`` overrides (issue 15): whatever a scenario holds, ``e2esim validate``
ends with status 0, or with status 2 and a message of one line, never with a traceback or a hang.

Scenarios start from small valid ones and get random changes at real and made-up key paths: values of
every YAML type (NaN, infinities, huge and tiny numbers, text, lists, mappings, null), deleted and added
keys, random sweeps, and sometimes a raw edit of the YAML text itself. Hypothesis draws one seed per example
and ``make_case`` builds the scenario from it with a seeded ``random.Random``: drawing every change through
Hypothesis costs four times the validation itself, and a failure prints the scenario and overrides anyway
(``note``). Validation runs in this process (``e2esim.cli.main``), so 500 examples take a few seconds. The
default suite runs a fixed, derandomised budget; ``-m slow`` runs a larger one seeded by E2ESIM_TEST_SEED.
"""

from __future__ import annotations

import contextlib
import io
import tempfile
from pathlib import Path

import pytest
import yaml
from hostile_files import hang_guard
from hypothesis import HealthCheck, given, note, seed, settings
from hypothesis import strategies as st

from e2esim import registry
from e2esim.cli import main
from e2esim.params import Param, ParamGroup
from helpers import TEST_SEED

_DUMPER = getattr(yaml, "CSafeDumper", yaml.SafeDumper)
HANG_S = 20  # an example that takes longer is a hang (a validation takes milliseconds)

BASES = [
    {"name": "f", "scene": {"type": "table1_forest", "forest": "boreal_200"}, "instrument": {"type": "biomass"},
     "requirements": [{"type": "agb_error_bound"}], "simulation": {"mode": "analytic"}},
    {"name": "g", "scene": {"type": "forest_agb_model", "biome": "boreal", "agb_t_ha": 150},
     "instrument": {"type": "gaussian_errors", "crosstalk": {"level_db": -30}},
     "ionosphere": {"type": "gaussian_faraday", "mean_deg": 10, "sd_deg": 2},
     "propagation": [{"type": "hv_backscatter_error"}, {"type": "backscatter_error_budget", "preset": "biomass_200m"}],
     "retrieval": {"type": "saturating"}, "requirements": [{"type": "agb_rmse"}],
     "simulation": {"mode": "both", "looks": 100, "realisations": 50},
     "sweep": {"parameters": {"scene.agb_t_ha": [50, 100], "instrument.nesz_db": [-30, -27]}}},
    {"name": "o", "orbit": {"type": "biomass_orbit", "site": {"lat_deg": 60, "lon_deg": 10},
                            "acquisitions": {"start": "2026-01-01", "end": "2026-03-01", "step_days": 20}},
     "scene": {"type": "covariance", "sigma_hh": 0.1, "sigma_hv": 0.02, "sigma_vv": 0.08, "hhvv_magnitude": 0.5},
     "instrument": {"type": "nisar"}, "ionosphere": {"type": "klobuchar_tec"},
     "calibration": [{"type": "transponder_calibration"}, {"type": "faraday_correction"}],
     "retrieval": {"type": "log_linear"}, "requirements": [{"type": "agb_rmse_absolute", "max_t_ha": 20}],
     "simulation": {"mode": "analytic"},
     "sweep": {"cases": [{"orbit.site.lat_deg": 10}, {"orbit.site.lat_deg": -40, "scene.sigma_hv": 0.03}]}},
]

SECTIONS = ("orbit", "scene", "instrument", "ionosphere", "calibration", "propagation", "retrieval", "requirements",
            "simulation", "sweep", "output", "name", "description", "plugins")
CHEAP_TYPES = {  # modules whose validation takes milliseconds (no climatology)
    "orbit": ("biomass_orbit", "sun_synchronous"), "scene": ("covariance", "forest_agb_model", "table1_forest"),
    "instrument": ("biomass", "gaussian_errors", "nisar"),
    "ionosphere": ("constant_faraday", "gaussian_faraday", "faraday_samples", "klobuchar_tec", "user_tec"),
    "calibration": ("none", "faraday_correction", "transponder_calibration", "distributed_target_calibration",
                    "radiometric_calibration"),
    "propagation": ("hv_backscatter_error", "backscatter_error_budget"),
    "retrieval": ("power_law", "saturating", "log_linear"),
    "requirement": ("agb_error_bound", "agb_rmse", "agb_rmse_absolute"),
}


def _leaf_keys() -> list:
    """Every parameter key path of the cheap modules, as (section, dotted parameter)."""
    out = []
    for kind, names in CHEAP_TYPES.items():
        for reg in registry.available(kind):
            if reg.type_name in names:
                stack = [(p, "") for p in reg.cls.params]
                while stack:
                    p, prefix = stack.pop()
                    if isinstance(p, ParamGroup):
                        stack += [(q, prefix + p.name + ".") for q in p.params]
                    elif isinstance(p, Param):  # not a constraint between parameters
                        key = ("requirements.0" if kind == "requirement" else kind, prefix + p.name)
                        PARAMS.setdefault(key, p)
                        out.append(key)
    out += [("simulation", k) for k in ("mode", "seed", "looks", "realisations", "noise_realisations", "keep_samples")]
    out += [("output", k) for k in ("folder", "title", "plots", "plot_x", "plot_group_by", "histogram_cases")]
    return sorted(set(out))


PARAMS: dict = {}  # (section, dotted name) -> Param, for values near what is allowed
LEAVES = _leaf_keys()
TYPES = [(("requirements.0" if kind == "requirement" else kind), name) for kind, names in CHEAP_TYPES.items()
         for name in names]

SPECIAL = [None, True, False, 0, 1, -1, 0.5, 90, 360, -90, 1e-300, 1e300, -1e300, 2**63, 10**400, 1e11, 5e-324,
           float("nan"), float("inf"), float("-inf"), -0.0, "boreal_200", "biomass", "both", "analytic", "2026-01-01",
           "nan", "1e5", "a:b", ":", ".x:Y", "this:x", "e2esim.scene.modules:Table1ForestScene", "/dev/zero",
           "../../etc/passwd", "", "\n", "x" * 300, "ünïcödé", "\x00", "!!python/name:os.system", "*a", "&a"]
RAW_EDITS = ["!!python/name:os.system ", "&a ", "*a", "<<: *a\n", "{", "]", ": ", "\t", "- ", "!!int ", "!!binary ",
             "!custom ", "\ufeff", "---\n", "%YAML 1.1\n", "? ", "|\n", "\x85", "\\U00110000"]
OTHER_PATHS = ["sweep.parameters", "sweep.cases", "sweep.mode", "requirements.1", "calibration.0",
               "sweep.parameters.scene.agb_t_ha", "sweep.cases.0", "plugins"]


def _text(rnd) -> str:
    return "".join(rnd.choice("abcxyz_.:0123456789-+ éü\t[]{},#&*!|>'\"") for _ in range(rnd.randint(0, 12)))


def _scalar(rnd):
    kind = rnd.randint(0, 5)
    if kind == 0:
        return rnd.choice(SPECIAL)
    if kind == 1:
        return rnd.randint(-10**6, 10**6)
    if kind == 2:
        return rnd.uniform(-1e3, 1e3) * 10 ** rnd.randint(-30, 30)
    if kind == 3:
        return _text(rnd)
    return rnd.choice(SPECIAL[:20])


def _value(rnd):
    kind = rnd.randint(0, 7)
    if kind == 0:
        return [_scalar(rnd) for _ in range(rnd.randint(0, 3))]
    if kind == 1:
        return {rnd.choice([_text(rnd), rnd.choice(SECTIONS)]): _scalar(rnd) for _ in range(rnd.randint(0, 2))}
    return _scalar(rnd)


def _plausible(rnd, param):
    """A value near what ``param`` allows: one of its choices, or a number around its bounds."""
    if param.choices:
        return rnd.choice(list(param.choices))
    if param.type == "bool":
        return rnd.random() < 0.5
    if param.type == "str":
        return rnd.choice(["2026-03-01", "x", "", "nominal"])
    lo = next((b for b in (param.minimum, param.exclusive_minimum) if b is not None), -100.0)
    hi = next((b for b in (param.maximum, param.exclusive_maximum) if b is not None), lo + 200.0)
    value = rnd.choice([lo, hi, rnd.uniform(lo, hi), rnd.uniform(lo - 1, hi + 1)])
    value = round(value) if param.type == "int" else value
    return [value] * (param.length or 1) if param.length or param.variable_length else value


def _key_path(rnd) -> str:
    kind = rnd.randint(0, 5)
    if kind <= 2:
        section, name = rnd.choice(LEAVES)
        return f"{section}.{name}"
    if kind == 3:
        return rnd.choice(SECTIONS)
    if kind == 4:
        return rnd.choice(OTHER_PATHS)
    return ".".join(_text(rnd).replace(".", "") or "k" for _ in range(rnd.randint(1, 3)))


def _set_in(data: dict, dotted: str, value) -> None:
    node = data
    parts = dotted.split(".")
    for part in parts[:-1]:
        key = int(part) if part.isdigit() else part
        if isinstance(node, list) and isinstance(key, int) and key < len(node):
            node = node[key]
        elif isinstance(node, dict):
            if not isinstance(node.get(key), (dict, list)):
                node[key] = {}
            node = node[key]
        else:
            return
    last = parts[-1]
    if isinstance(node, dict):
        node[last] = value
    elif isinstance(node, list) and last.isdigit() and int(last) < len(node):
        node[int(last)] = value


def make_case(seed: int) -> tuple[str, list]:
    """A scenario text and ``--set`` overrides from ``seed``: a base with random changes at real and made-up key
    paths, sometimes a raw edit of the YAML text."""
    import copy
    import random

    rnd = random.Random(seed)
    data = copy.deepcopy(rnd.choice(BASES))
    for _ in range(rnd.randint(0, 4)):
        action = rnd.choice(["set", "set", "set", "type", "delete", "sweep"])
        if action == "set" and rnd.random() < 0.5:  # a real parameter, a value near what it allows
            section, name = rnd.choice(LEAVES)
            if (section, name) in PARAMS:
                _set_in(data, f"{section}.{name}", _plausible(rnd, PARAMS[section, name]))
        elif action == "set":
            _set_in(data, _key_path(rnd), _value(rnd))
        elif action == "type":
            section, name = rnd.choice(TYPES)
            _set_in(data, f"{section}.type", name)
        elif action == "delete" and data:
            data.pop(rnd.choice(list(data)))
        elif action == "sweep":
            section, name = rnd.choice(LEAVES)
            data["sweep"] = {"parameters": {f"{section}.{name}": [_value(rnd) for _ in range(rnd.randint(1, 3))]}}
    text = yaml.dump(data, Dumper=_DUMPER, sort_keys=False, allow_unicode=rnd.random() < 0.5)
    if rnd.random() < 0.2:  # a raw edit: YAML syntax, tags, anchors, odd characters
        pos = rnd.randint(0, len(text))
        text = text[:pos] + rnd.choice(RAW_EDITS + [_text(rnd)]) + text[pos:]
    sets = []
    for _ in range(rnd.choice([0, 0, 1, 2])):
        value = _value(rnd)
        shown = _text(rnd) if rnd.random() < 0.2 else yaml.dump(value, Dumper=_DUMPER, default_flow_style=True)
        sets.append(f"{_key_path(rnd)}={shown.strip().removesuffix('...').strip()}")
    return text, sets



_FOLDER = Path(tempfile.mkdtemp(prefix="e2esim-fuzz-"))


def check_validate(text: str, sets: list) -> None:
    """``e2esim validate`` on ``text`` with ``sets``: status 0, or 2 with one line; anything else fails."""
    path = _FOLDER / "scenario.yaml"
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    out, err = io.StringIO(), io.StringIO()
    with hang_guard(HANG_S), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main(["validate", str(path), *(f"--set={s}" for s in sets)])
    message = err.getvalue()
    assert status in (0, 2), (status, message)
    if status == 2:
        assert message.startswith("e2esim: error: ") and message.count("\n") == 1, repr(message)
    else:
        assert message == "" and "valid;" in out.getvalue()


COMMON = dict(deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow])
SEEDS = st.integers(min_value=0, max_value=2**64 - 1)


@settings(max_examples=500, derandomize=True, **COMMON)
@given(case_seed=SEEDS)
def test_validate_never_crashes(case_seed):
    text, sets = make_case(case_seed)
    note(f"scenario:\n{text}\n--set: {sets}")
    check_validate(text, sets)


@pytest.mark.slow
@seed(TEST_SEED)
@settings(max_examples=5000, **COMMON)
@given(case_seed=SEEDS)
def test_validate_never_crashes_large_budget(case_seed):
    text, sets = make_case(case_seed)
    note(f"scenario:\n{text}\n--set: {sets}")
    check_validate(text, sets)
