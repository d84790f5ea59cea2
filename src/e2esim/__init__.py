"""e2esim: end-to-end mission performance simulator for spaceborne polarimetric SAR biomass missions.

The physics lives in small, vectorised kernels (``e2esim.polarimetry``, ``e2esim.distortion``, ...);
modules that a scenario names wrap them (``e2esim.module``); the runner, I/O, report and command
line sit on top (``e2esim.runner``, ``e2esim.io``, ``e2esim.report``, ``e2esim.cli``).
"""

__version__ = "0.1.0"
