"""Words with units for sweep keys on plot axes and in legends: a table for the keys of the shipped
scenarios, and for any other key its name made readable with the unit its ending states."""

from __future__ import annotations

AXIS_LABELS = {
    "orbit.site.lat_deg": "site latitude (deg)",
    "orbit.site.lon_deg": "site longitude (deg)",
    "orbit.site.name": "site",
    "orbit.passes": "pass",
    "orbit.altitude_km": "orbit altitude (km)",
    "scene.agb_t_ha": "above-ground biomass (t/ha)",
    "scene.forest": "forest (Men et al. 2021, Table I)",
    "scene.biome": "biome",
    "scene.sigma_hv": "σ_hv (m²/m²)",
    "instrument.centre_frequency_mhz": "centre frequency (MHz)",
    "instrument.nesz_db": "NESZ (dB)",
    "instrument.crosstalk.level_db": "crosstalk level (dB)",
    "instrument.channel_imbalance.level_db": "channel-imbalance level (dB)",
    "ionosphere.mean_deg": "mean Faraday rotation (deg)",
    "ionosphere.sd_deg": "SD of the Faraday rotation (deg)",
    "ionosphere.solar": "solar activity",
    "ionosphere.tec_variability": "day-to-day TEC variability (fraction)",
    "simulation.looks": "looks",
    "simulation.seed": "seed",
}

_UNITS = (("_t_ha", "t/ha"), ("_percent", "%"), ("_deg", "deg"), ("_db", "dB"), ("_mhz", "MHz"), ("_hz", "Hz"),
          ("_km", "km"), ("_m2", "m²"), ("_m", "m"), ("_fraction", "fraction"))


def axis_label(key: str) -> str:
    """``orbit.site.lat_deg`` -> "site latitude (deg)"; an unknown key -> its last words with their unit."""
    if key in AXIS_LABELS:
        return AXIS_LABELS[key]
    # list items are numbered from 1 in words: calibration.1.type -> "calibration 2 type"
    parts = [str(int(p) + 1) if p.isdigit() else p for p in key.split(".")]
    last = parts[-1]
    suffix = next((s for s, _ in _UNITS if last.endswith(s)), None)
    unit = dict(_UNITS)[suffix] if suffix else None
    if suffix:
        last = last[: -len(suffix)]
    head = parts[-3:-1] if len(parts) > 2 and parts[-2].isdigit() else parts[-2:-1]
    words = " ".join(p.replace("_", " ") for p in head + [last] if p)
    return f"{words} ({unit})" if unit else words


def value_text(key: str, value) -> str:
    """A sweep value for a legend or a facet title: ``solar activity max``, ``above-ground biomass 50 t/ha``."""
    label = axis_label(key)
    name, _, unit = label.partition(" (")
    shown = f"{value:g}" if isinstance(value, float) else str(value)
    return f"{name} {shown} {unit[:-1]}".strip() if unit else f"{name} {shown}"


def wrapped(text: str, width: int) -> str:
    """``text`` on lines of at most about ``width`` characters, broken after the commas between a label's
    ``key=value`` parts (a part longer than a line keeps a line of its own): a label is shown whole, never cut."""
    lines: list = []
    for part in str(text).split(", "):
        if lines and len(lines[-1]) + 2 + len(part) <= width:
            lines[-1] += ", " + part
        else:
            if lines:
                lines[-1] += ","
            lines.append(part)
    return "\n".join(lines)
