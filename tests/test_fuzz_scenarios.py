"""Fuzzing of scenario files and ``--set`` overrides (issue 15): whatever a scenario holds, ``e2esim validate``
ends with status 0, or with status 2 and a message of one line, never with a traceback or a hang.

Scenarios start from small valid ones and get random changes at real and made-up key paths: values of
every YAML type (NaN, infinities, huge and tiny numbers, text, lists, mappings, null), deleted and added
keys, random sweeps, and sometimes a raw edit of the YAML text itself. Validation runs in this process
(``e2esim.cli.main``), so a few hundred examples take seconds. The default suite runs a fixed,
derandomised budget; ``-m slow`` runs a larger one seeded by E2ESIM_TEST_SEED.
"""

from __future__ import annotations

import contextlib
import io
import signal
import tempfile
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st

from e2esim import registry
from e2esim.cli import main
from e2esim.params import ParamGroup
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
                    else:
                        out.append(("requirements.0" if kind == "requirement" else kind, prefix + p.name))
    out += [("simulation", k) for k in ("mode", "seed", "looks", "realisations", "noise_realisations", "keep_samples")]
    out += [("output", k) for k in ("folder", "title", "plots", "plot_x", "plot_group_by", "histogram_cases")]
    return sorted(set(out))


LEAVES = _leaf_keys()
TYPES = [(("requirements.0" if kind == "requirement" else kind), name) for kind, names in CHEAP_TYPES.items()
         for name in names]

scalars = st.one_of(
    st.none(), st.booleans(),
    st.integers(min_value=-10**6, max_value=10**6), st.integers(min_value=-10**400, max_value=10**400),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, 1, -1, 1e-300, 1e300, -1e300, 2**63, 0.5, 90, 360, -90, 1e11, 5e-324]),
    st.text(max_size=12),
    st.sampled_from(["boreal_200", "biomass", "both", "analytic", "2026-01-01", "nan", "1e5", "a:b", ":", ".x:Y",
                     "this:x", "e2esim.scene.modules:Table1ForestScene", "/dev/zero", "../../etc/passwd", "", "\n",
                     "x" * 300, "ünïcödé", "\x00"]),
)
values = st.recursive(scalars, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.dictionaries(st.one_of(st.text(max_size=8), st.sampled_from(SECTIONS)), inner,
                                                 max_size=3)), max_leaves=8)
key_paths = st.one_of(
    st.sampled_from(LEAVES).map(lambda t: f"{t[0]}.{t[1]}"),
    st.sampled_from(SECTIONS),
    st.sampled_from(["sweep.parameters", "sweep.cases", "sweep.mode", "requirements.1", "calibration.0",
                     "sweep.parameters.scene.agb_t_ha", "sweep.cases.0", "plugins"]),
    st.lists(st.text(alphabet="abcxyz_.0123:", min_size=1, max_size=6), min_size=1, max_size=4).map(".".join),
)


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


@st.composite
def scenario_texts(draw):
    """A scenario's YAML text: a base with random changes, sometimes with a raw edit of the text."""
    import copy

    data = copy.deepcopy(draw(st.sampled_from(BASES)))
    for _ in range(draw(st.integers(0, 4))):
        action = draw(st.sampled_from(["set", "set", "set", "type", "delete", "sweep"]))
        if action == "set":
            _set_in(data, draw(key_paths), draw(values))
        elif action == "type":
            section, name = draw(st.sampled_from(TYPES))
            _set_in(data, f"{section}.type", name)
        elif action == "delete":
            key = draw(st.sampled_from(list(data))) if data else None
            data.pop(key, None)
        else:
            key = draw(st.sampled_from(LEAVES))
            data["sweep"] = {"parameters": {f"{key[0]}.{key[1]}": draw(st.lists(values, min_size=1, max_size=3))}}
    text = yaml.dump(data, Dumper=_DUMPER, sort_keys=False, allow_unicode=draw(st.booleans()))
    if draw(st.integers(0, 5)) == 0:  # a raw edit: YAML syntax, tags, anchors, odd characters
        pos = draw(st.integers(0, len(text)))
        insert = draw(st.one_of(st.text(max_size=6), st.sampled_from(
            ["!!python/name:os.system ", "&a ", "*a", "<<: *a\n", "{", "]", ": ", "\t", "- ", "!!int ", "!!binary ",
             "!custom ", "\ufeff", "---\n", "%YAML 1.1\n", "? ", "|\n"])))
        text = text[:pos] + insert + text[pos:]
    return text


overrides = st.lists(st.builds(lambda k, v: f"{k}={v}", key_paths, st.one_of(
    values.map(lambda v: yaml.safe_dump(v, default_flow_style=True).strip().removesuffix("...").strip()),
    st.text(max_size=10))), max_size=2)


@contextlib.contextmanager
def _hang_guard(seconds: int):
    def _raise(signum, frame):
        raise TimeoutError(f"validation took more than {seconds} s: a hang")

    old = signal.signal(signal.SIGALRM, _raise)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


_FOLDER = Path(tempfile.mkdtemp(prefix="e2esim-fuzz-"))


def check_validate(text: str, sets: list) -> None:
    """``e2esim validate`` on ``text`` with ``sets``: status 0, or 2 with one line; anything else fails."""
    path = _FOLDER / "scenario.yaml"
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    out, err = io.StringIO(), io.StringIO()
    with _hang_guard(HANG_S), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main(["validate", str(path), *(f"--set={s}" for s in sets)])
    message = err.getvalue()
    assert status in (0, 2), (status, message)
    if status == 2:
        assert message.startswith("e2esim: error: ") and message.count("\n") == 1, repr(message)
    else:
        assert message == "" and "valid;" in out.getvalue()


COMMON = dict(deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


@settings(max_examples=500, derandomize=True, **COMMON)
@given(text=scenario_texts(), sets=overrides)
def test_validate_never_crashes(text, sets):
    check_validate(text, sets)


@pytest.mark.slow
@seed(TEST_SEED)
@settings(max_examples=5000, **COMMON)
@given(text=scenario_texts(), sets=overrides)
def test_validate_never_crashes_large_budget(text, sets):
    check_validate(text, sets)
