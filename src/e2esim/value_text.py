"""A value of a scenario as an error message quotes it: YAML-like, on one line, cut to a readable length."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any


def number_text(x: float) -> str:
    short = f"{x:g}"
    return str(x) if isinstance(x, int) and float(short) != x else short  # an integer bound is shown exactly


LARGEST_NUMBER = 10**300  # integers beyond this are not numbers a scenario means (and overflow a float)
SHOW_CHARS = 80  # a value quoted in a message is cut to about this length


def value_text(value: Any) -> str:
    """A value as a message quotes it: YAML-like, on one line, cut to ``SHOW_CHARS``."""
    if isinstance(value, str):
        text = repr(value)
    elif isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, (list, tuple)):
        text = "[" + ", ".join(value_text(v) for v in value[:20]) + (", ...]" if len(value) > 20 else "]")
    elif isinstance(value, Mapping):
        text = "a mapping"
    elif isinstance(value, int) and not -LARGEST_NUMBER < value < LARGEST_NUMBER:
        text = f"an integer of {len(str(abs(value))) if abs(value) < 10**4000 else 'over 4000'} digits"
    else:
        text = repr(value) if not isinstance(value, (int, float)) else number_text(value)
    return text if len(text) <= SHOW_CHARS else text[:SHOW_CHARS] + "..."
