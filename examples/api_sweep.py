"""A sweep from Python: how the AGB error of BIOMASS depends on crosstalk, for two forests.

    python examples/api_sweep.py [OUTPUT_FOLDER]

It runs a scenario given as a dict (no file) with ``e2esim.run``, looks at the results as a pandas table and
as an xarray Dataset whose dimensions are the swept variables, plots the 99.865 % quantile of the relative AGB
error against the crosstalk level, and writes the usual run folder (results.h5, summary.json, report) next to
the plot. ``e2esim.open_results`` reads that folder back into the same interface.
"""

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import e2esim

SCENARIO = {
    "name": "api_crosstalk_sweep",
    "scene": {"type": "table1_forest"},
    "instrument": {"type": "biomass"},
    "ionosphere": {"type": "gaussian_faraday", "mean_deg": 60.0, "sd_deg": 5.0},
    "propagation": {"type": "hv_backscatter_error"},
    "retrieval": {"type": "power_law"},
    "requirements": [{"type": "agb_error_bound", "bound_percent": 20}],
    "simulation": {"mode": "analytic", "seed": 1},
    "sweep": {"parameters": {"scene.forest": ["boreal_200", "tropical_338"],
                             "instrument.crosstalk.level_db": {"linspace": [-35, -20, 4]}}},
}


def main(folder: Path) -> Path:
    results = e2esim.run(SCENARIO, **{"simulation.looks": 100_000})  # overrides: dotted keys, as --set

    df = results.to_dataframe()                      # one row per case, the sweep keys as columns
    print(df[["scene.forest", "instrument.crosstalk.level_db", "agb.analytic.q99865_percent"]].head())

    ds = results.to_xarray()                         # dimensions: scene.forest x instrument.crosstalk.level_db
    q = ds["agb.analytic.q99865_percent"]
    fig, ax = plt.subplots(figsize=(6, 4))
    for forest in ds["scene.forest"].values:
        line = q.sel({"scene.forest": forest})
        ax.plot(line["instrument.crosstalk.level_db"], line, "o-", label=forest)
    ax.axhline(20, color="k", ls="--", lw=0.8, label="20 % bound")
    ax.set_xlabel("crosstalk level (dB, 3-sigma amplitude)")
    ax.set_ylabel(f"AGB error, 99.865 % quantile ({q.attrs['units']})")
    ax.legend()
    folder.mkdir(parents=True, exist_ok=True)
    fig.savefig(folder / "agb_error_vs_crosstalk.png", dpi=100, bbox_inches="tight")
    plt.close(fig)

    results.write(folder / "run")                    # results.h5, summary.json, report.md/html, plots
    again = e2esim.open_results(folder / "run")      # the same interface, read from results.h5
    assert again.to_xarray()["agb.analytic.q99865_percent"].shape == q.shape
    return folder / "agb_error_vs_crosstalk.png"


if __name__ == "__main__":
    print(main(Path(sys.argv[1] if len(sys.argv) > 1 else "runs/api_sweep")))
