"""The check a stage's products pass before they join the case (docs/architecture.md, "The chain")."""

from __future__ import annotations


def checked_products(stage, new) -> dict:
    """``new`` if it holds exactly the products ``stage`` declares, each of its declared type."""
    declared = {p.name: p for p in stage.provides}
    if not isinstance(new, dict) or set(new) != set(declared):
        got = ", ".join(new) if isinstance(new, dict) else type(new).__name__
        raise TypeError(f"{stage.identity} returned {got or 'nothing'}; it declares {', '.join(declared) or 'nothing'}")
    for name, value in new.items():
        declared[name].check(value, stage.identity)
    return new
