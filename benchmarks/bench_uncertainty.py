"""The uncertainty product (issue 26, "Speed"): ``e2esim uncertainty`` on a NISAR GCOV of N x N pixels (default
5,000 x 5,000; target <= 60 s and <= 4 GB on two cores), next to two references measured in the same run:

1. the I/O floor: the same product read band by band (the four covariance grids, the looks and the mask) and the
   same float32 layers (``LAYERS``) written to NetCDF and Cloud-Optimised GeoTIFF, without the model (the writer of
   ``e2esim.products_io.uncertainty_files`` handed zeros): what any per-pixel product of this grid costs;
2. the per-case path: ``hv_error_moments`` (the reference the batched kernel must equal) called pixel by pixel on
   ``--per-case-pixels`` pixels (default 2,000), scaled to the grid.

Each measurement runs in a fresh process (``--one``) so that its peak resident memory (ru_maxrss) is its own. The
product is generated with the test writer's layout (tests/product_writers.py) in a temporary folder. Nothing here
asserts a time; the machine's load is printed first: compare figures of the same run only. The model runs in one
process each; the model in two worker processes (``--workers 2``), the target being stated for two cores.
``--size 1000``: a smoke run.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def write_product(path: Path, n: int, rows: int | None = None) -> None:
    """A GCOV of ``rows`` (default n) x n pixels in the layout of tests/product_writers.write_gcov, written by blocks
    of rows."""
    import h5py

    sys.path.insert(0, str(ROOT))
    from tests.product_writers import write_gcov

    rows = n if rows is None else rows
    write_gcov(path, shape=(2, n))  # every metadata variable; the grids are replaced below at full size
    rng = np.random.default_rng(0)
    grids = "/science/LSAR/GCOV/grids/frequencyA"
    with h5py.File(path, "r+") as f:
        for name, dtype in (("HHHH", "f4"), ("HVHV", "f4"), ("VVVV", "f4"), ("HHVV", "c8"), ("numberOfLooks", "f4"),
                            ("mask", "u1"), ("yCoordinates", "f8")):
            attrs = dict(f[f"{grids}/{name}"].attrs)
            del f[f"{grids}/{name}"]
            shape = (rows,) if name == "yCoordinates" else (rows, n)
            ds = f.create_dataset(f"{grids}/{name}", shape, dtype, chunks=None if name == "yCoordinates" else
                                  (min(rows, 512), min(n, 512)))
            ds.attrs.update(attrs)
            if name == "yCoordinates":
                ds[:] = 6650000.0 - 20.0 * np.arange(rows)
                continue
            for start in range(0, rows, 512):
                band = slice(start, min(start + 512, rows))
                hv = rng.uniform(0.02, 0.08, (band.stop - start, n))
                ds[band, :] = {"HHHH": 4 * hv, "HVHV": hv, "VVVV": 2.5 * hv,
                               "HHVV": 0.3 * np.sqrt(10.0) * hv * np.exp(0.3j), "numberOfLooks": 25.0 + 0 * hv,
                               "mask": np.ones_like(hv)}[name]


def measure(kind: str, product: str, out: str, per_case_pixels: int) -> dict:
    t0 = time.perf_counter()
    if kind == "model":
        from e2esim.products_io.uncertainty import write_uncertainty

        summary = write_uncertainty(product, out, force=True, workers=2)
        extra = {"pixels_with_data": summary["pixels_with_data"]}
    elif kind == "io_floor":
        from e2esim.products_io.pixel_model import LAYERS
        from e2esim.products_io.uncertainty import open_product, row_bands
        from e2esim.products_io.uncertainty_files import UncertaintyWriter

        pixels = open_product(product)
        bands = list(row_bands(pixels.shape))
        writer = UncertaintyWriter(out, pixels, {"reference": "I/O floor"}, force=True,
                                   band_rows=bands[0].stop - bands[0].start)
        for rows in bands:
            block = pixels.read(rows)
            zeros = np.zeros(block.valid.shape)
            writer.write(rows, {name: zeros.astype(np.uint8) if name == "verdict" else zeros for name in LAYERS})
        writer.commit()
        extra = {}
    else:  # per_case
        from e2esim.distortion.analytic import hv_error_moments
        from e2esim.products_io.assumptions import load_assumptions
        from e2esim.scene.covariance import ScatteringCovariance

        a = load_assumptions(None, "nisar")
        rng = np.random.default_rng(1)
        t0 = time.perf_counter()
        for hv in rng.uniform(0.02, 0.08, per_case_pixels):
            hhvv = 0.3 * np.sqrt(10.0) * hv * np.exp(0.3j)
            c = np.array([[4 * hv, 0, hhvv], [0, hv, 0], [np.conj(hhvv), 0, 2.5 * hv]])
            hv_error_moments(ScatteringCovariance(c), a.system, a.faraday, looks=25.0, noise_power=0.003)
        extra = {"pixels": per_case_pixels}
    seconds = time.perf_counter() - t0
    usage = [resource.getrusage(who) for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)]
    return {"seconds": seconds, "cpu_seconds": sum(u.ru_utime + u.ru_stime for u in usage),
            "main_cpu_seconds": usage[0].ru_utime + usage[0].ru_stime,
            "peak_rss_gb": max(u.ru_maxrss for u in usage) / 2**20, "load_after": os.getloadavg()[0], **extra}


def load_text(load_before: float, result: dict) -> str:
    """The one-minute load average before and after a measurement: its wall time is the machine's, not the code's,
    when the load exceeds the cores."""
    return f"load {load_before:.1f} -> {result['load_after']:.1f} on {os.cpu_count()} cores"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=int, default=5000, help="grid of SIZE x SIZE pixels (default 5000)")
    parser.add_argument("--rows", type=int, default=None, help="rows of the grid (default SIZE): a grid of other "
                        "width, e.g. --rows 2000 --size 12500, shows whether memory grows with the width")
    parser.add_argument("--only", choices=("model", "io_floor", "per_case"), nargs="+",
                        default=("model", "io_floor", "per_case"), help="measure these only")
    parser.add_argument("--per-case-pixels", type=int, default=2000)
    parser.add_argument("--product", help="an existing product written by this benchmark (default: write one)")
    parser.add_argument("--one", nargs=3, metavar=("KIND", "PRODUCT", "OUT"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        print(json.dumps(measure(*args.one, args.per_case_pixels)))
        return
    rows = args.rows or args.size
    pixels = rows * args.size
    print(f"load average: {os.getloadavg()}; grid {rows} x {args.size} = {pixels:,} pixels")
    with tempfile.TemporaryDirectory(prefix="bench_uncertainty_") as tmp:
        product = Path(args.product or Path(tmp) / "gcov.h5")
        t0 = time.perf_counter()
        if not args.product:
            write_product(product, args.size, rows)
        print(f"product written in {time.perf_counter() - t0:.1f} s ({product.stat().st_size / 2**20:,.0f} MiB)")
        results, loads = {}, {}
        for kind in args.only:
            loads[kind] = os.getloadavg()[0]
            run = subprocess.run([sys.executable, __file__, "--one", kind, str(product), str(Path(tmp) / kind),
                                  "--per-case-pixels", str(args.per_case_pixels)], capture_output=True, text=True,
                                 check=True)
            results[kind] = json.loads(run.stdout.strip().splitlines()[-1])
        if "model" in results:
            model = results["model"]
            print(f"e2esim uncertainty: {model['seconds']:.1f} s ({model['cpu_seconds']:.1f} CPU s, the workers' "
                  f"included; {model['main_cpu_seconds']:.1f} in the writing process), peak "
                  f"{model['peak_rss_gb']:.2f} GB of one process ({model['pixels_with_data']:,} pixels with data; "
                  f"target <= 60 s and <= 4 GB at 5,000 x 5,000; {load_text(loads['model'], model)})")
            bound = max(model["cpu_seconds"] / 2, model["main_cpu_seconds"])
            print(f"  on two quiet cores it takes at least {bound:.1f} s (its CPU time over two, or the writing "
                  "process's, whichever is larger: an estimate, a bound)")
        if "io_floor" in results:
            floor = results["io_floor"]
            print(f"I/O floor (read the grids, write the layers as zeros): {floor['seconds']:.1f} s "
                  f"({floor['cpu_seconds']:.1f} CPU s), peak "
                  f"{floor['peak_rss_gb']:.2f} GB ({load_text(loads['io_floor'], floor)})")
        if "per_case" in results:
            per_case = results["per_case"]
            scaled = per_case["seconds"] / per_case["pixels"] * pixels
            print(f"per-case path: {per_case['seconds'] / per_case['pixels'] * 1e3:.2f} ms a pixel, {scaled:,.0f} s "
                  "for the grid")

if __name__ == "__main__":
    main()
