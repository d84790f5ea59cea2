"""Benchmark of the Faraday-rotation climatology (issue "FR climatology", Speed).

Targets: a global 2 x 2 deg climatology for dawn and dusk passes, 12 months, solar minimum and maximum,
in under 5 minutes on 2 cores; read back from its HDF5 cache in under 1 s. Also times the kernels against
their references in the same run: e2esim's IGRF synthesis against ppigrf, and the pointwise IRI against
PyIRI's own (outer-product) call.

    python benchmarks/bench_climatology.py [--step 2] [--workers 2] [--cache DIR] [--maps docs/theory/img]

Prints the times and ratios; ``--maps`` also writes the maps and latitude profiles of the climatology.
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import tempfile
import time
from pathlib import Path

import numpy as np

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # one BLAS thread per worker process


def bench_igrf(n: int = 100_000) -> None:
    from e2esim.geomag.igrf import igrf_geocentric, igrf_reference

    rng = np.random.default_rng(0)
    r = 6371.2e3 + rng.uniform(0, 700e3, n)
    th = rng.uniform(0.01, np.pi - 0.01, n)
    ph = rng.uniform(-np.pi, np.pi, n)
    igrf_geocentric(r[:10], th[:10], ph[:10], "2026-01-01")
    t0 = time.perf_counter()
    fast = igrf_geocentric(r, th, ph, "2026-01-01")
    t1 = time.perf_counter()
    ref = igrf_reference(r, th, ph, "2026-01-01")
    t2 = time.perf_counter()
    err = max(float(np.max(np.abs(a - b))) for a, b in zip(fast, ref))
    print(f"IGRF, {n} points: e2esim {t1 - t0:.2f} s, ppigrf {t2 - t1:.2f} s, ratio {(t2 - t1) / (t1 - t0):.1f}x, "
          f"max difference {err:.1e} T")


def bench_iri(n: int = 16_200) -> None:
    import PyIRI
    import PyIRI.main_library as ml

    from e2esim.ionosphere import iri

    lon, lat = (a.ravel() for a in np.meshgrid(np.arange(-179.0, 180.0, 2.0), np.arange(-89.0, 90.0, 2.0)))
    ut = np.mod(6.0 - lon / 15.0, 24.0)  # one UT per point: the dawn pass
    alt = np.arange(60.0, 667.0, 10.0)
    iri.electron_density(dt.date(2026, 3, 3), ut[:5], lon[:5], lat[:5], alt, 100.0)
    t0 = time.perf_counter()
    iri.electron_density(dt.date(2026, 3, 3), ut, lon, lat, alt, 100.0)
    t1 = time.perf_counter()
    ml.IRI_density_1day(2026, 3, 3, np.array([6.0]), lon, lat, alt, 100.0, PyIRI.coeff_dir, 1)
    t2 = time.perf_counter()
    print(f"IRI profiles, {lon.size} points x {alt.size} heights: e2esim (one UT per point) {t1 - t0:.2f} s, "
          f"PyIRI IRI_density_1day (one UT for all) {t2 - t1:.2f} s, ratio {(t2 - t1) / (t1 - t0):.1f}x "
          f"(PyIRI needs one call per distinct UT for a satellite pass)")


def bench_climatology(step: float, workers: int, cache: Path, maps: Path | None) -> None:
    from concurrent.futures import ProcessPoolExecutor

    from e2esim.faraday.global_climatology import global_climatology
    from e2esim.io.array_cache import ArrayCache
    from e2esim.ionosphere.slant import SlantSettings
    from e2esim.orbit.sunsync import SunSynchronousOrbit

    orbit = SunSynchronousOrbit(666e3)  # BIOMASS: dawn (ascending) and dusk (descending) passes
    pool = ProcessPoolExecutor(workers) if workers > 1 else None
    kw = dict(step_deg=step, months=range(1, 13), f107=(70.0, 180.0), settings=SlantSettings("thin_shell"),
              cache=ArrayCache(cache), executor=pool)
    t0 = time.perf_counter()
    clim = global_climatology(orbit, **kw)
    t1 = time.perf_counter()
    again = global_climatology(orbit, **kw)
    if pool is not None:
        pool.shutdown()
    t2 = time.perf_counter()
    stats = again.statistics(435e6)
    t3 = time.perf_counter()
    n_rays = int(np.isfinite(clim.faraday[:, 0]).sum())
    print(f"global climatology {step:g} x {step:g} deg, 12 months, dawn + dusk, F10.7 {clim.f107}, "
          f"{clim.incidence_deg.size} swath positions: {n_rays} rays x 2 solar levels, {t1 - t0:.1f} s on "
          f"{workers} worker(s) (target < 300 s: {'met' if t1 - t0 < 300 else 'NOT met'})")
    size_mb = sum(a.nbytes for a in (clim.faraday, clim.stec, clim.vtec)) / 1e6
    print(f"cache read-back {t2 - t1:.3f} s (target < 1 s: {'met' if t2 - t1 < 1 else 'NOT met'}); "
          f"statistics at 435 MHz {t3 - t2:.3f} s; table {size_mb:.0f} MB")
    with np.errstate(invalid="ignore"):
        for i, lab in enumerate(clim.pass_labels):
            for j, f in enumerate(clim.f107):
                m = stats["mean_abs_deg"][i, j]
                print(f"  {lab:4s} F10.7 {f:5.0f}: global mean |Omega| {np.nanmean(m):5.1f} deg, max "
                      f"{np.nanmax(m):5.1f} deg, mean SD {np.nanmean(stats['sd_deg'][i, j]):5.1f} deg")
    if maps is not None:
        from e2esim.report.faraday_plots import plot_global_maps, plot_latitude_profiles

        maps.mkdir(parents=True, exist_ok=True)
        fr_map = clim.map(435e6, 0.25)
        plot_global_maps(fr_map, maps / "fr_map_mean_abs.png", "mean_abs_deg")
        plot_global_maps(fr_map, maps / "fr_map_sd.png", "sd_deg")
        plot_global_maps(fr_map, maps / "fr_map_mean.png", "mean_deg")
        plot_latitude_profiles(fr_map, maps / "fr_latitude_profiles.png")
        print(f"maps written to {maps}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--step", type=float, default=2.0, help="grid step (deg)")
    ap.add_argument("--workers", type=int, default=2, help="processes")
    ap.add_argument("--cache", type=Path, default=None, help="cache folder (default: a fresh temporary one)")
    ap.add_argument("--maps", type=Path, default=None, help="write maps into this folder")
    args = ap.parse_args()
    print(f"e2esim climatology benchmark, {os.cpu_count()} CPU(s) visible")
    bench_igrf()
    bench_iri()
    if args.cache is None:
        with tempfile.TemporaryDirectory() as tmp:
            bench_climatology(args.step, args.workers, Path(tmp), args.maps)
    else:
        bench_climatology(args.step, args.workers, args.cache, args.maps)


if __name__ == "__main__":
    main()
