"""The scenario keys a solve varies: which parameter a dotted key names, whether it is numeric, its allowed range.

A key is a dotted path as ``--set`` takes it (``instrument.crosstalk.level_db``, ``calibration.0.sd_deg``); it
names a parameter (``e2esim.params.Param``) of a module of the scenario, built-in or plug-in, found through the
module's location in the scenario and its declared parameters.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from e2esim.errors import UserError
from e2esim.key_paths import override_path
from e2esim.params import Param, ParamGroup


@dataclass(frozen=True)
class SolveKey:
    """A numeric scenario key: its dotted name, its parameter, the allowed range (lo, hi) and whether it is an
    integer (evaluated at whole values)."""

    name: str
    param: Param
    lo: float
    hi: float

    @property
    def integer(self) -> bool:
        return self.param.type == "int"

    def value(self, x: float):
        return round(x) if self.integer else float(x)


def _params_of(params, rest: tuple):
    """The ``Param`` at ``rest`` (a path inside a module's parameters), or None."""
    for p in params:
        if isinstance(p, ParamGroup) and rest and p.name == rest[0]:
            return _params_of(p.params, rest[1:])
        if isinstance(p, Param) and len(rest) == 1 and p.name == rest[0]:
            return p
    return None


def solve_key(resolved, key: str, option: str = "--for") -> SolveKey:
    """The ``SolveKey`` of dotted ``key`` in ``resolved`` (a ``ResolvedScenario``). Raises ``UserError`` (exit 2) for
    a key that names no parameter of the scenario's modules, a key the sweep sets, and a parameter that is not one
    number (text, a switch, a list)."""
    if key in resolved.sweep_keys:
        raise UserError(f"{option} {key}: the sweep sets this key; solve finds its value for every case, so take it "
                        f"out of the sweep (--replace-sweep {key}=VALUE)")
    path = override_path(key)
    for module in resolved.cases[0].modules:
        where = tuple(module.location.key_path)
        if tuple(path[:len(where)]) != where or len(path) == len(where):
            continue
        param = _params_of(type(module).params, tuple(path[len(where):]))
        if param is None:
            break
        if param.type not in ("float", "int") or param.length is not None or param.variable_length:
            kind = "a list" if (param.length or param.variable_length) else f"of type {param.type}"
            raise UserError(f"{option} {key}: not a numeric parameter ({kind}); solve varies one number "
                            "(e.g. instrument.crosstalk.level_db, calibration.0.sd_deg)")
        lo = next((v for v in (param.minimum, param.exclusive_minimum) if v is not None), -math.inf)
        hi = next((v for v in (param.maximum, param.exclusive_maximum) if v is not None), math.inf)
        return SolveKey(key, param, float(lo), float(hi))
    modules = ", ".join(".".join(map(str, m.location.key_path)) for m in resolved.cases[0].modules)
    raise UserError(f"{option} {key}: unknown key: it names no parameter of this scenario's modules ({modules}); "
                    "`e2esim modules KIND` lists each module's parameters")


def bounds_of(key: SolveKey, given) -> tuple:
    """(lo, hi) of the search: ``given`` (``--bounds LO HI``), else the parameter's allowed range. An exclusive
    limit is moved inside by a relative 1e-9; an unbounded side needs ``--bounds``."""
    if given is not None:
        lo, hi = (float(v) for v in given)
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise UserError(f"--bounds {given[0]} {given[1]}: expected two finite numbers LO < HI")
        if lo < key.lo or hi > key.hi:
            raise UserError(f"--bounds {lo:g} {hi:g}: outside the allowed range of {key.name} "
                            f"({key.lo:g} to {key.hi:g})")
        return lo, hi
    lo, hi = key.lo, key.hi
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise UserError(f"--for {key.name}: its allowed range is not bounded ({lo:g} to {hi:g}); give --bounds LO HI")
    if key.param.exclusive_minimum is not None:
        lo += 1e-9 * max(1.0, abs(lo))
    if key.param.exclusive_maximum is not None:
        hi -= 1e-9 * max(1.0, abs(hi))
    return lo, hi
