"""Constraints between the parameters of one section, declared in its ``params`` next to them: ``ExactlyOneOf``,
``AtMostOneOf``, ``Requires``, ``Ordered`` (``e2esim.params`` checks them and re-exports them)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from e2esim.errors import ConfigError, Location
from e2esim.value_text import value_text


class Constraint:
    """A rule between parameters of one section, declared in its ``params`` next to them and checked with
    them (so docs/scenario-reference.md lists it too)."""

    names: tuple = ()

    def check(self, values: Mapping, where: Location) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def describe(self) -> str:  # pragma: no cover - abstract
        raise NotImplementedError

    def __eq__(self, other: object) -> bool:
        return type(self) is type(other) and vars(self) == vars(other)

    def __hash__(self) -> int:
        return hash((type(self), self.names))

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.describe()})"


def _given(values: Mapping, names) -> list:
    return [n for n in names if values.get(n) is not None]


class ExactlyOneOf(Constraint):
    """Exactly one of the named parameters is given (not null)."""

    def __init__(self, *names: str):
        self.names = tuple(names)

    def check(self, values, where):
        given = _given(values, self.names)
        if len(given) != 1:
            problem = "none of them is given" if not given else f"{', '.join(given)} are all given"
            raise ConfigError(where.child(given[1] if given else self.names[0]), problem,
                              f"give exactly one of {', '.join(self.names)}")

    def describe(self) -> str:
        return f"exactly one of {', '.join(self.names)}"


class AtMostOneOf(Constraint):
    """At most one of the named parameters is given (not null)."""

    def __init__(self, *names: str):
        self.names = tuple(names)

    def check(self, values, where):
        given = _given(values, self.names)
        if len(given) > 1:
            raise ConfigError(where.child(given[1]), f"{', '.join(given)} are all given",
                              f"give at most one of {', '.join(self.names)}")

    def describe(self) -> str:
        return f"at most one of {', '.join(self.names)}"


class Requires(Constraint):
    """``name`` must be given (not null) when parameter ``when`` has the value ``equals``."""

    def __init__(self, name: str, when: str, equals: Any):
        self.names = (name, when)
        self.name, self.when, self.equals = name, when, equals

    def check(self, values, where):
        if values.get(self.when) == self.equals and values.get(self.name) is None:
            raise ConfigError(where.child(self.name), f"is null, but {self.when} is {value_text(self.equals)}",
                              f"give {self.name} when {self.when} is {value_text(self.equals)}")

    def describe(self) -> str:
        return f"{self.name} is required when {self.when} is {value_text(self.equals)}"


class Ordered(Constraint):
    """``lower < upper`` for two parameters, or ``value[0] < value[1]`` for one two-item parameter."""

    def __init__(self, lower: str, upper: str | None = None):
        self.names = (lower,) if upper is None else (lower, upper)
        self.lower, self.upper = lower, upper

    def check(self, values, where):
        if self.upper is None:
            pair = values.get(self.lower)
            if pair is not None and not pair[0] < pair[1]:
                raise ConfigError(where.child(self.lower), f"{value_text(list(pair))} is not an increasing range",
                                  "expected [low, high] with low < high")
            return
        lo, hi = values.get(self.lower), values.get(self.upper)
        if lo is not None and hi is not None and not lo < hi:
            raise ConfigError(where.child(self.lower), f"{value_text(lo)} is not below {self.upper} = {value_text(hi)}",
                              f"expected {self.lower} < {self.upper}")

    def describe(self) -> str:
        if self.upper is None:
            return f"{self.lower} is an increasing range"
        return f"{self.lower} < {self.upper}"
