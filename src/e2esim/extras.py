"""The optional extras: what the default scenario does not need, installed only on request.

``pip install e2esim`` brings the core (what ``scenarios/biomass_default.yaml`` needs: the chain, IRI and IGRF,
results.h5, the report and its plots). Each extra below brings the packages of one wing; ``pip install
'e2esim[all]'`` brings every one, and ``make test`` installs them all. Code that needs an extra imports its
packages through ``optional_import``, so that a missing one ends in a message naming the extra and the pip
command (``MissingExtraError``, a ``UserError``: the command line prints it and exits with status 2), never in
an ImportError traceback. The lists here and [project.optional-dependencies] in pyproject.toml must agree
(tests/test_extras.py checks it).
"""

from __future__ import annotations

import importlib

from e2esim.errors import MissingExtraError

EXTRAS = {
    "maps": ("map sweeps over the globe (land mask, results.nc) and Results.to_xarray",
             ("xarray", "netCDF4", "roaring_landmask")),
    "products": ("AGB maps read from product files (NetCDF, GeoTIFF) by scene.agb_map; e2esim uncertainty on a "
                 "BIOMASS L1 or NISAR GCOV product", ("xarray", "netCDF4", "rioxarray", "rasterio")),
    "cluster": ("sweeps on a dask.distributed cluster (e2esim run --scheduler)", ("distributed",)),
    "orbits": ("two-line element sets propagated with SGP4 (orbit type orbit_file with a TLE)", ("sgp4",)),
}
"""{extra: (what it is for, the modules it brings, as imported)}."""


def install_command(extra: str) -> str:
    return f"pip install 'e2esim[{extra}]'"


def optional_import(module: str, extra: str, purpose: str):
    """The module ``module`` (a dotted name) of the optional extra ``extra``, imported; ``MissingExtraError`` if it
    (or a package it needs) is not installed. ``purpose`` says what needed it, e.g. "reading a GeoTIFF AGB map"."""
    if extra not in EXTRAS:
        raise ValueError(f"unknown extra {extra!r}; expected one of {', '.join(EXTRAS)}")
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        missing = getattr(exc, "name", None) or module
        raise MissingExtraError(f"{purpose} needs the optional extra '{extra}' ({missing} is not installed): "
                                f"{install_command(extra)} (in a checkout, `make test` installs every extra)") from exc


def require_extra(extra: str, purpose: str) -> None:
    """Every module of ``extra`` importable, or ``MissingExtraError``: checked before work that needs them at its
    end (a map sweep writes results.nc only after its last case)."""
    for module in EXTRAS[extra][1]:
        optional_import(module, extra, purpose)


__all__ = ["EXTRAS", "MissingExtraError", "install_command", "optional_import", "require_extra"]
