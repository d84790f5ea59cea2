"""The parser of ``e2esim uncertainty``, and its command imported only when it runs (start-up time of the
command line)."""

from __future__ import annotations

import importlib


def add_parser(sub) -> None:
    p = sub.add_parser(
        "uncertainty", help="per-pixel error budget of a BIOMASS L1 or NISAR GCOV, RSLC or GSLC product",
        description="On the product's own grid, the predicted error moments of sigma_hv, the Faraday-rotation "
                    "estimate's SD (the product's own, or filled), the residual Faraday rotation, the AGB error and "
                    "the verdict per pixel, as CF NetCDF (uncertainty.nc) and Cloud-Optimised GeoTIFF "
                    "(uncertainty.tif). What the product does not hold is taken from the scenario and listed in the "
                    "outputs' attributes (docs/real-data.md). Needs the 'products' extra.")
    p.add_argument("product", help="a BIOMASS L1 product folder (annotation XML and LUT NetCDF) or a NISAR GCOV, "
                                   "RSLC or GSLC HDF5 file")
    p.add_argument("--scenario", metavar="FILE", help="scenario whose first case gives the assumptions (default: "
                                                      "the shipped assumptions of the product's mission)")
    p.add_argument("-o", "--output", metavar="DIR", default="uncertainty", help="output folder (default: "
                                                                                "./uncertainty)")
    p.add_argument("--force", action="store_true", help="replace outputs that exist")
    p.add_argument("--workers", type=int, default=1, metavar="N", help="processes that evaluate the pixels "
                                                                        "(default 1: this process)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")


def _cmd_uncertainty(args) -> int:
    return importlib.import_module("e2esim.products_io.commands").cmd_uncertainty(args)


COMMANDS = {"uncertainty": _cmd_uncertainty}
