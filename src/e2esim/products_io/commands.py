"""``e2esim uncertainty``: the command (``e2esim.products_io.parsers`` adds its parser to the command line and
imports this module only when the command runs)."""

from __future__ import annotations

import json

from e2esim.products_io.uncertainty import write_uncertainty


def cmd_uncertainty(args) -> int:
    summary = write_uncertainty(args.product, args.output, args.scenario, args.force, workers=args.workers)
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
