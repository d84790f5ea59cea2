"""``e2esim uncertainty``: its parser and its command (the command line imports this module; the work is in
``e2esim.products_io.uncertainty``)."""

from __future__ import annotations

import json


def add_parser(sub) -> None:
    p = sub.add_parser(
        "uncertainty", help="per-pixel error budget of a BIOMASS L1 or NISAR GCOV product",
        description="On the product's own grid, the predicted error moments of sigma_hv, the Faraday-rotation "
                    "estimate's SD (the product's own, or filled), the residual Faraday rotation, the AGB error and "
                    "the verdict per pixel, as CF NetCDF (uncertainty.nc) and Cloud-Optimised GeoTIFF "
                    "(uncertainty.tif). What the product does not hold is taken from the scenario and listed in the "
                    "outputs' attributes (docs/real-data.md). Needs the 'products' extra.")
    p.add_argument("product", help="a BIOMASS L1 product folder (annotation XML and LUT NetCDF) or a NISAR GCOV "
                                   "HDF5 file")
    p.add_argument("--scenario", metavar="FILE", help="scenario whose first case gives the assumptions (default: "
                                                      "the shipped assumptions of the product's mission)")
    p.add_argument("-o", "--output", metavar="DIR", default="uncertainty", help="output folder (default: "
                                                                                "./uncertainty)")
    p.add_argument("--force", action="store_true", help="replace outputs that exist")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")


def cmd_uncertainty(args) -> int:
    from e2esim.products_io.uncertainty import write_uncertainty  # lazy: start-up time

    summary = write_uncertainty(args.product, args.output, args.scenario, args.force)
    if args.json:
        print(json.dumps(summary, indent=2, default=str))
        return 0
    passing = summary["fraction_passing"]
    verdict = "no pixel with data" if passing is None else (
        f"{100 * passing:.1f} % meet the AGB error bound ({100 * summary['assumed_agb_error_bound']:g} % at "
        f"{100 * summary['assumed_agb_error_confidence']:.3f} %)")
    print(f"{summary['mission']} product {args.product}: {summary['shape'][0]} x {summary['shape'][1]} pixels, "
          f"{summary['pixels_with_data']} with data; {verdict}")
    print(f"Faraday rotation corrected by the processor: {summary['faraday_rotation_corrected_by_processor']}; "
          f"crosstalk corrected: {summary['crosstalk_corrected_by_processor']}; assumptions from "
          f"{summary['assumptions_scenario']}")
    for path in summary["outputs"]:
        print(f"wrote {path}")
    return 0


COMMANDS = {"uncertainty": cmd_uncertainty}
