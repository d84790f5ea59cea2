"""Import PyIRI without its plotting module.

PyIRI's package ``__init__`` imports ``PyIRI.plotting``, which imports matplotlib: about a second in every
process that computes a climatology (each worker of a global map), for plots e2esim never draws. Before
PyIRI is first imported, ``import_pyiri`` registers a stand-in for ``PyIRI.plotting`` that loads the real
module on first use of any of its attributes, so PyIRI's own plotting keeps working for anyone who calls it.
(``importlib.util.LazyLoader`` cannot do this on Python 3.11: the import system reads the module's
``__spec__``, which already triggers the load.)
"""

from __future__ import annotations

import importlib.util
import sys
import types

_PLOTTING = "PyIRI.plotting"


class _DeferredModule(types.ModuleType):
    """A module whose attributes come from the real one, imported on first access."""

    def __init__(self, name: str, spec):
        super().__init__(name)
        self._e2esim_spec = spec  # its own state: found by plain look-up, so ``__getattr__`` never sees this name

    def __getattr__(self, attr):
        # the import system's and inspect's look-ups; the spec itself is always set (asked here, it would recurse)
        if (attr.startswith("__") and attr.endswith("__")) or attr == "_e2esim_spec":
            raise AttributeError(attr)
        spec = self._e2esim_spec
        real = importlib.util.module_from_spec(spec)
        sys.modules[self.__name__] = real
        spec.loader.exec_module(real)
        parent, _, child = self.__name__.rpartition(".")
        if parent in sys.modules:
            setattr(sys.modules[parent], child, real)
        return getattr(real, attr)


def import_pyiri():
    """``PyIRI`` with its plotting module deferred (see the module docstring); returns the package."""
    if "PyIRI" not in sys.modules and _PLOTTING not in sys.modules:
        package = importlib.util.find_spec("PyIRI")  # a top-level spec: finding it imports nothing
        locations = package.submodule_search_locations if package is not None else None
        if locations:
            spec = importlib.util.spec_from_file_location(_PLOTTING, f"{locations[0]}/plotting.py")
            if spec is not None and spec.loader is not None:
                sys.modules[_PLOTTING] = _DeferredModule(_PLOTTING, spec)
    import PyIRI

    return PyIRI
