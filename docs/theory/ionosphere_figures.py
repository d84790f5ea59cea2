"""Make the figures of docs/theory/ionosphere.md (written to docs/theory/img/).

    python docs/theory/ionosphere_figures.py [--cache DIR]

The global maps come from the 2 deg climatology of benchmarks/bench_climatology.py (read from the cache if
it is there, else computed: about a minute on 2 cores).
"""

from __future__ import annotations

import argparse
import datetime as dt
from dataclasses import replace
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
from concurrent.futures import ProcessPoolExecutor

import matplotlib.pyplot as plt
import numpy as np

from e2esim.faraday.global_climatology import global_climatology
from e2esim.io.array_cache import ArrayCache
from e2esim.ionosphere.geolocation import TABLE1_ASSUMPTIONS, b_dot_k_profile, delay_error_threshold
from e2esim.ionosphere.propagation import faraday_rotation_integral
from e2esim.ionosphere.slant import SlantSettings, path_integrals
from e2esim.orbit.geometry import view_geometry
from e2esim.orbit.sunsync import SunSynchronousOrbit
from e2esim.report.faraday_plots import plot_global_maps, plot_latitude_profiles

IMG = Path(__file__).resolve().parent / "img"
ORBIT = SunSynchronousOrbit(666e3)
F = 435e6


def maps(cache: Path | None) -> None:
    with ProcessPoolExecutor(2) as pool:
        clim = global_climatology(ORBIT, 2.0, f107=(70.0, 180.0), settings=SlantSettings("thin_shell"), executor=pool,
                                  cache=None if cache is None else ArrayCache(cache), progress=_bar)
    fr_map = clim.map(F, 0.25)
    plot_global_maps(fr_map, IMG / "fr_map_mean_abs.png", "mean_abs_deg")
    plot_global_maps(fr_map, IMG / "fr_map_sd.png", "sd_deg")
    plot_global_maps(fr_map, IMG / "fr_map_mean.png", "mean_deg")
    plot_latitude_profiles(fr_map, IMG / "fr_latitude_profiles.png")


def _bar(iterable, total, description):
    from tqdm.auto import tqdm

    return tqdm(iterable, total=total, desc=description)


def slant_methods() -> None:
    """Omega along a meridian by the three slant models, and the thin-shell error."""
    lat = np.arange(-80.0, 78.1, 2.0)
    fig, axes = plt.subplots(2, 2, figsize=(11, 7), sharex=True)
    for col, (pass_name, f107, month, lon) in enumerate((("descending", 180.0, 12, 100.0),
                                                         ("ascending", 70.0, 3, 20.0))):
        g = view_geometry(ORBIT, np.radians(lat), np.radians(lon), np.radians(28.4), pass_name)
        ut = np.mod(g.local_time_h - lon / 15, 24)
        res = {}
        for m in ("thin_shell", "pierce_profile", "multilayer"):
            p = path_integrals(g.target_ecef, g.satellite_ecef, dt.date(2026, month, 15), ut, (f107,),
                               SlantSettings(m))
            res[m] = np.degrees(faraday_rotation_integral(p.faraday[0], F))
        ax, bx = axes[0, col], axes[1, col]
        for m, style in (("multilayer", "k-"), ("pierce_profile", "b--"), ("thin_shell", "r:")):
            ax.plot(lat, res[m], style, label=m)
        for m, style in (("pierce_profile", "b--"), ("thin_shell", "r:")):
            bx.plot(lat, res[m] - res["multilayer"], style, label=f"{m} - multilayer")
        label = ORBIT.pass_label(pass_name)
        ax.set_title(f"{label}, F10.7 {f107:g} sfu, {dt.date(2026, month, 15):%B}, {lon:g} deg E, incidence 28.4 deg",
                     fontsize=9)
        ax.set_ylabel("Ω at 435 MHz (deg)")
        bx.set_ylabel("difference (deg)")
        bx.set_xlabel("target latitude (deg)")
        for a in (ax, bx):
            a.grid(alpha=0.3)
            a.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(IMG / "fr_slant_methods.png", dpi=110)
    plt.close(fig)


def table1() -> None:
    """B.k near the magnetic equator under the Table 1 assumptions, with the four thresholds."""
    tlat = np.linspace(-3, 6, 901)
    qlat, bk = b_dot_k_profile(TABLE1_ASSUMPTIONS, tlat)
    fig, ax = plt.subplots(figsize=(8, 4.2))
    ax.plot(qlat, np.abs(bk) * 1e9, "k-", label="|B.k| (aligned dipole, incidence 26 deg, 300 km)")
    colors = plt.get_cmap("tab10")
    for i, (snr, looks) in enumerate(((10, 100), (10, 10000), (20, 100), (20, 10000))):
        thr = delay_error_threshold(snr, looks, TABLE1_ASSUMPTIONS)
        thr_p = delay_error_threshold(snr, looks, replace(TABLE1_ASSUMPTIONS, variance_form="printed"))
        ax.axhline(thr * 1e9, color=colors(i), ls="-", lw=1, label=f"SNR {snr} dB, L = {looks} (corrected eq. 5)")
        ax.axhline(thr_p * 1e9, color=colors(i), ls=":", lw=1)
    ax.set_yscale("log")
    ax.set_ylim(5, 3e4)
    ax.set_xlabel("latitude of the 300 km pierce point (deg)")
    ax.set_ylabel("|B.k| (nT)")
    ax.set_title("Where the 25 m (99 %) geolocation requirement fails: |B.k| below the line (dotted: eq. 5 as printed)",
                 fontsize=9)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(IMG / "table1_zone.png", dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--cache", type=Path, default=None)
    a = ap.parse_args()
    IMG.mkdir(parents=True, exist_ok=True)
    slant_methods()
    table1()
    maps(a.cache)
