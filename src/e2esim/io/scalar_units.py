"""Units and one-line descriptions of the output scalars, for the attributes of results.h5 and for the
Results API. The names follow docs/output-format.md: an output scalar takes its unit from the product that
made it (``e2esim.products.Product.units``: ``scene.sigma_hv`` in m^2/m^2), a plug-in's too; otherwise the unit
is at the end of its name (``_percent``, ``_db``, ``_deg``, ...). A name neither gives a unit gets the unit
"unknown", never a guess.
"""

from __future__ import annotations

import re

from e2esim import products as P
from e2esim.units import DIMENSIONLESS

TEXT = "text"  # units of string datasets

_SUFFIX_UNITS = (
    ("_fraction_standard_error", DIMENSIONLESS), ("_probability_standard_error", DIMENSIONLESS),
    ("_t_ha", "t/ha"), ("_percent", "%"), ("_db", "dB"), ("_deg", "deg"), ("_mhz", "MHz"), ("_hz", "Hz"),
    ("_tecu", "TECU"), ("_ut", "uT"), ("_sfu", "sfu"), ("_m", "m"), ("_fraction", DIMENSIONLESS),
    ("_probability", DIMENSIONLESS), ("variance_share", DIMENSIONLESS), ("_pvalue", DIMENSIONLESS),
)
"""Units written at the end of a name (longest match first where two share an ending)."""

_GROUPS = {
    "scene": "scattering covariance of the scene",
    "faraday": "one-way Faraday rotation before any correction",
    "faraday_residual": "Faraday rotation the propagation applies after calibration",
    "instrument": "the instrument's specification as the scenario states it",
    "system": "system errors after calibration (what the propagation applies)",
    "analytic": "analytic moments of the sigma_hv error (Men et al. 2021)",
    "montecarlo": "Monte Carlo moments of the sigma_hv error",
    "comparison": "Monte Carlo against analytic, (MC - analytic) / analytic (Men et al. 2021, eq. 18)",
    "calibration": "calibration steps and their results",
    "budget": "random-error budget of sigma0 at the product scale (Ahmed et al. 2014)",
    "agb": "relative AGB error",
}


def scalar_unit(name: str, requirement_units: tuple = (), products=P.BUILT_IN) -> str:
    """The unit of output scalar ``name``: the one its product declares (``products``: the declarations of the
    run's products, e2esim's own by default; ``e2esim.runner.records.run_products``), else the unit at the end
    of its name; ``requirement_units`` give ``requirement<j>.value``/``margin``."""
    return _unit(name, requirement_units, _longest_prefix_first(products))


def scalar_units(names, requirement_units: tuple = (), products=P.BUILT_IN) -> list:
    """``scalar_unit`` of each of ``names``, the products ordered once (results.h5 has hundreds of scalars)."""
    ordered = _longest_prefix_first(products)
    return [_unit(name, requirement_units, ordered) for name in names]


_REQUIREMENT_SCALAR = re.compile(r"requirement(\d+)\.(value|margin)")


def _longest_prefix_first(products) -> list:
    """[(prefix of its scalars' names, product)] of the products that write scalars, a longer prefix (more
    specific) first."""
    ordered = sorted(products, key=lambda p: -len(p.scalars or ""))
    return [(f"{p.scalars}." if p.scalars else "", p) for p in ordered if p.scalars is not None]


def _unit(name: str, requirement_units: tuple, ordered: list) -> str:
    match = _REQUIREMENT_SCALAR.fullmatch(name)
    if match:
        j = int(match.group(1))
        return requirement_units[j] if j < len(requirement_units) else "unknown"
    for prefix, product in ordered:
        unit = product.unit_of(name) if name.startswith(prefix) else None
        if unit is not None:
            return unit
    for suffix, unit in _SUFFIX_UNITS:
        if name.endswith(suffix):
            return unit
    return "unknown"


def run_products(scenario) -> tuple:
    """The product declarations that give a run's output scalars their units: e2esim's own and those of the
    run's chains (a plug-in's)."""
    plan = getattr(scenario, "plan", None)
    return (*P.BUILT_IN, *(plan.products() if plan is not None else ()))


def scalar_description(name: str) -> str:
    """One line: what the scalar's group is and which quantity (docs/output-format.md has the details)."""
    group, _, quantity = name.partition(".")
    if re.fullmatch(r"requirement\d+", group):
        return f"requirement {group[len('requirement'):]}: {quantity} (in the requirement's unit)"
    about = _GROUPS.get(group, f"output of the {group} product")
    return f"{about}: {quantity.replace('_', ' ')} (docs/output-format.md)"


def detail_unit(key: str, unit: str) -> str:
    """Unit of a verdict detail (``crosstalk.margin_db``, ``contribution.noise_percent``...)."""
    if key == "margin_within_uncertainty":
        return "1 (the margin is inside 1.96 standard errors of the value) or 0"
    if key == "basis_disagreement":
        return "0 (agree), 1 (differ: shape of the distribution) or 2 (differ: moments)"
    found = scalar_unit(key)
    return found if found != "unknown" else unit
