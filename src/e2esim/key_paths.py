"""The key path that a dotted setting key names in a scenario.

Used by the command-line changes to a scenario (``e2esim.runner.overrides``), by the report of settings that change
nothing (``e2esim.runner.no_effect``) and by stages that say which settings they cannot depend on
(``Stage.insensitivity``).
"""

from __future__ import annotations


def override_path(key: str) -> tuple:
    """Key path of a dotted override key; under ``sweep.parameters`` and ``sweep.cases.I`` the rest of
    the key is one sweep key (``sweep.parameters.scene.agb_t_ha`` -> ("sweep", "parameters",
    "scene.agb_t_ha"))."""
    parts = key.split(".")
    if parts[:2] == ["sweep", "parameters"] and len(parts) > 2:
        return ("sweep", "parameters", ".".join(parts[2:]))
    if parts[:2] == ["sweep", "cases"] and len(parts) > 3 and parts[2].isdigit():
        return ("sweep", "cases", int(parts[2]), ".".join(parts[3:]))
    return tuple(int(p) if p.isdigit() else p for p in parts)
