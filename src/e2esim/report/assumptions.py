"""The assumptions a verdict rests on: each setting of the chain's modules, its value and where it comes
from (the scenario, the sweep, or a module's default or preset, with the source the code gives for it).

Nothing is invented here: values are the resolved modules' settings, the budget preset's values
(``e2esim.budget.presets``, whose comment on each value names its source) and the scalars the chain wrote.
"""

from __future__ import annotations

import ast
import inspect
import io
import tokenize

from e2esim.params import iter_params
from e2esim.report.blocks import fmt

KEY_SETTINGS = {
    "instrument": ("crosstalk.level_db", "crosstalk.convention", "crosstalk.correlation_magnitude",
                   "channel_imbalance.level_db", "channel_imbalance.convention", "nesz_db", "centre_frequency_mhz",
                   "bandwidth_mhz", "gain_offset_db", "gain_sd_db"),
    "propagation": ("preset", "observation.observations", "observation.speckle_diverse_observations",
                    "observation.product_resolution_m", "observation.area_m2", "temporal.sd_percent",
                    "temporal.sd_m2m2", "instrument.random_calibration_db", "combination", "include",
                    "variance_form", "reference"),
    "ionosphere": None,  # every setting
    "calibration": None,
    "retrieval": ("exponent", "regression.mode", "alpha", "ground_cancelled_exponent", "ground_cancelled_exponents",
                  "model_uncertainty.mode", "model_uncertainty.exponent_sd_percent",
                  "model_uncertainty.reference_agb_t_ha"),
    "scene": None,
}
"""Settings a verdict depends on most, per module kind (None: all of the kind's settings)."""

PRESET_FIELDS = {  # budget setting -> (preset field, factor to the setting's unit)
    "observation.observations": ("observations", 1.0),
    "observation.speckle_diverse_observations": ("diverse_observations", 1.0),
    "observation.area_m2": ("area_m2", 1.0),
    "temporal.sd_percent": ("temporal_relative_sd", 100.0),
    "instrument.random_calibration_db": ("random_calibration_db", 1.0),
}


def assumption_rows(resolved, looks_of_cases=()) -> tuple[list, list]:
    """(key rows, other rows): (setting, value, source) of every module setting of the first case; key rows
    are those of ``KEY_SETTINGS``, the budget's preset values and derived looks (``looks_of_cases``: the scalar
    budget.looks of the cases that have it)."""
    raw = resolved.raw
    swept = set(resolved.sweep_keys)
    key_rows, other_rows = [], []
    counters: dict = {}
    for module in resolved.cases[0].modules if resolved.cases else []:
        if module.kind == "requirement":
            continue
        position = counters.get(module.kind, 0)
        counters[module.kind] = position + 1
        section = raw.get(module.kind)
        prefix = f"{module.kind}.{position}." if isinstance(section, list) else f"{module.kind}."
        given = section[position] if isinstance(section, list) and position < len(section) else section
        keys = KEY_SETTINGS.get(module.kind, ())
        for name, param in iter_params(module.params):
            value = _get(module.config, name)
            dotted = prefix + name
            if dotted in swept:
                source = "swept: see the cases"
            elif isinstance(given, dict) and _get(given, name, _MISSING) is not _MISSING:
                source = "the scenario"
            else:
                source = f"default of {module.kind} type '{module.type_name}': {param.doc}"
            shown = _value(value, param.unit)
            if (value is None and name in PRESET_FIELDS and module.type_name == "backscatter_error_budget"
                    and PRESET_FIELDS[name][0] in _preset(module.config["preset"])):
                field, factor = PRESET_FIELDS[name]
                preset = module.config["preset"]
                shown, source = _preset_value(preset, field, factor, param.unit)
            row = (f"`{dotted}`", shown, source)
            (key_rows if keys is None or name in keys else other_rows).append(row)
        if module.type_name == "backscatter_error_budget":
            looks = sorted(float(x) for x in (min(looks_of_cases), max(looks_of_cases))) if len(looks_of_cases) else []
            if looks:
                span = fmt(looks[0], 3) if looks[0] == looks[-1] else f"{fmt(looks[0], 3)} to {fmt(looks[-1], 3)}"
                key_rows.append(("looks of the product (speckle)", span, "computed from the product area, the "
                                 "resolution and the observations (Ahmed et al. 2014, eq. 22); scalar budget.looks"))
    sim = resolved.cases[0].settings if resolved.cases else None
    if sim is not None:
        for name in ("mode", "looks", "realisations"):
            source = "the scenario" if name in (raw.get("simulation") or {}) else "default of the simulation section"
            key_rows.append((f"`simulation.{name}`", fmt(getattr(sim, name)), source))
    return key_rows, other_rows


_MISSING = object()


def _preset(name: str) -> dict:
    from e2esim.budget import presets

    return presets.PRESETS[name]


def _get(mapping, dotted: str, default=None):
    node = mapping
    for part in dotted.split("."):
        if not isinstance(node, dict) or part not in node:
            return default
        node = node[part]
    return node


def _value(value, unit: str) -> str:
    if isinstance(value, (list, tuple)):
        value = ", ".join(fmt(v) for v in value)
    text = fmt(value) if value is not None else "null (automatic)"
    return f"{text} {unit}".strip() if value is not None and unit else text


def _preset_value(preset: str, field: str, factor: float, unit: str) -> tuple:
    from e2esim.budget import presets

    value = presets.PRESETS[preset][field]
    comment = preset_comments(presets).get((preset, field), "")
    source = f"budget preset '{preset}'" + (f": {comment}" if comment else "")
    return _value(float(value) * factor, unit), source


def preset_comments(module) -> dict:
    """{(preset, field): comment} from the source of ``e2esim.budget.presets``: each value's comment there
    names its source ("CEOS EO Handbook: ...", "assumed: ..."). Empty when the source is not available."""
    try:
        source = inspect.getsource(module)
    except (OSError, TypeError):
        return {}
    comments = {tok.start[0]: tok.string.lstrip("# ").strip()
                for tok in tokenize.generate_tokens(io.StringIO(source).readline) if tok.type == tokenize.COMMENT}
    names = {key.upper(): key for key in module.PRESETS}  # BIOMASS_200M = dict(...) is preset biomass_200m
    out = {}
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Assign) and isinstance(node.value, ast.Call) and len(node.targets) == 1:
            target = getattr(node.targets[0], "id", "")
            preset = names.get(target)
            if preset is None:
                continue
            for kw in node.value.keywords:
                text = comments.get(kw.value.end_lineno)
                if text:
                    out[(preset, kw.arg)] = text
    return out
