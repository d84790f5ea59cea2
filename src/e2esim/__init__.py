"""e2esim: end-to-end mission performance simulator for spaceborne polarimetric SAR biomass missions.

The physics lives in small, vectorised kernels (``e2esim.polarimetry``, ``e2esim.distortion``, ...);
modules that a scenario names wrap them (``e2esim.module``); the runner, I/O, report and command
line sit on top (``e2esim.runner``, ``e2esim.io``, ``e2esim.report``, ``e2esim.cli``).

The Python API (``e2esim.api``): ``e2esim.run(scenario, **overrides)`` returns a ``Results``;
``e2esim.open_results(path)`` reads a results.h5 back into the same interface; ``e2esim.solve`` and
``e2esim.allocate`` flow a requirement down (``e2esim.flowdown``).
"""

__version__ = "0.1.0"

_API = {"run": "e2esim.api", "open_results": "e2esim.api", "load_scenario": "e2esim.api", "Results": "e2esim.results",
        "solve": "e2esim.flowdown.inverse", "allocate": "e2esim.flowdown.allocation"}


def __getattr__(name):  # imported on first use: `import e2esim` stays light for the command line
    if name in _API:
        import importlib

        return getattr(importlib.import_module(_API[name]), name)
    raise AttributeError(f"module 'e2esim' has no attribute {name!r}")


__all__ = ["Results", "__version__", "allocate", "load_scenario", "open_results", "run", "solve"]
