"""Units and one-line descriptions of the output scalars, for the attributes of results.h5 and for the
Results API. The names follow docs/output-format.md: the unit is in the name (``_percent``, ``_db``,
``_deg``, ...) or fixed by its group (``scene.sigma_hv`` in m^2/m^2). A name no rule knows (a plug-in's
output) gets the unit "unknown", never a guess.
"""

from __future__ import annotations

import re

SIGMA = "m^2/m^2"
SIGMA_SQUARED = "(m^2/m^2)^2"
DIMENSIONLESS = "1"
TEXT = "text"  # units of string datasets

_SUFFIX_UNITS = (
    ("_fraction_standard_error", DIMENSIONLESS), ("_probability_standard_error", DIMENSIONLESS),
    ("_t_ha", "t/ha"), ("_percent", "%"), ("_db", "dB"), ("_deg", "deg"), ("_mhz", "MHz"), ("_hz", "Hz"),
    ("_tecu", "TECU"), ("_ut", "uT"), ("_sfu", "sfu"), ("_m", "m"), ("_fraction", DIMENSIONLESS),
    ("_probability", DIMENSIONLESS), ("variance_share", DIMENSIONLESS), ("_pvalue", DIMENSIONLESS),
)
"""Units written at the end of a name (longest match first where two share an ending)."""

_RULES = (
    (r"scene\.(sigma_hh|sigma_hv|sigma_vv|hhvv_magnitude)", SIGMA),
    (r"scene\.agb_t_ha", "t/ha"),
    (r"system\.(crosstalk_variance|imbalance_variance)", DIMENSIONLESS),
    (r"system\.noise_power", SIGMA),
    (r"system\..*gain.*", "dB"),
    (r"analytic\.(mean|sd|bias_\w+)", SIGMA),
    (r"analytic\.(variance|var_\w+)", SIGMA_SQUARED),
    (r"montecarlo\.(mean|sd|mean_se)", SIGMA),
    (r"montecarlo\.(variance|variance_se)", SIGMA_SQUARED),
    (r"montecarlo\.(samples|realisations)", "count"),
    (r"montecarlo\.(skewness|excess_kurtosis|ks_distance)", DIMENSIONLESS),
    (r"comparison\.\w+", DIMENSIONLESS),
    (r"budget\.looks", "count"),
    (r"calibration\.steps", "count"),
    (r"calibration\..*chi2_mean", DIMENSIONLESS),
    (r"calibration\.residual\.(max_abs_correlation_outside_pairs|max_crosstalk_noncircularity)", DIMENSIONLESS),
    (r"faraday(_residual)?\.tec_variability", DIMENSIONLESS),
    (r"agb\.exponent", DIMENSIONLESS),
    (r"agb\.contribution\.\w+\.campaigns(_failed)?", "count"),
    (r"requirement\d+\.passed", "1 (pass), 0 (fail) or NaN (not applicable)"),
)

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


def scalar_unit(name: str, requirement_units: tuple = ()) -> str:
    """The unit of output scalar ``name``; ``requirement_units`` give ``requirement<j>.value``/``margin``."""
    match = re.fullmatch(r"requirement(\d+)\.(value|margin)", name)
    if match:
        j = int(match.group(1))
        return requirement_units[j] if j < len(requirement_units) else "unknown"
    for pattern, unit in _RULES:
        if re.fullmatch(pattern, name):
            return unit
    for suffix, unit in _SUFFIX_UNITS:
        if name.endswith(suffix):
            return unit
    return "unknown"


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
