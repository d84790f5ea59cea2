"""Write the small BIOMASS L1 product that scenarios/biomass_default_from_product.yaml reads
(scenarios/data/biomass_l1_siberia/: annotation.xml and lut.nc, 16 x 20 pixels, about 0.1 MB).

The files are written by the test writers (tests/product_writers.py: the BPS v4.3.0 layout, from its XSDs and LUT
writer), so the shipped product has exactly the layout the readers and the tests check. It is a generated product,
not a mission file: its values are chosen, not measured. The grid lies at latitude 60.00-60.15 N, longitude
92.00-92.19 E (central Siberia, the boreal site of biomass_default); incidence 23 to 33.75 deg across range.

* Faraday rotation (``ionosphereCorrection/faradayRotation``): a plane from 4.0 deg at the first pixel, +0.1 deg per
  azimuth row and +0.05 deg per range column (4.0 to 6.45 deg); ``faradayRotationStd`` left empty (the no-data fill),
  as the BPS writes it.
* Noise (``denoising/denoising*``): -28 dB at near range to -26 dB at far range (the same in the three channels).
* RFI (annotation ``rfiTMReport/percentageAffectedLines``): HH 2.0 %, HV 3.5 %, VH 3.0 %, VV 1.5 %.

Run ``python tools/make_product_scenario_data.py`` (needs the test dependencies: netCDF4); the test
tests/test_product_scenario.py checks that the shipped files hold these values.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
FOLDER = ROOT / "scenarios" / "data" / "biomass_l1_siberia"
SHAPE = (16, 20)
RFI_PERCENT = {"HH": 2.0, "HV": 3.5, "VH": 3.0, "VV": 1.5}


def faraday_deg(shape=SHAPE) -> np.ndarray:
    rows, cols = np.indices(shape)
    return 4.0 + 0.1 * rows + 0.05 * cols


def noise_db(shape=SHAPE) -> np.ndarray:
    return np.broadcast_to(np.linspace(-28.0, -26.0, shape[1]), shape)


def write(folder=FOLDER) -> Path:
    sys.path.insert(0, str(ROOT / "tests"))
    from product_writers import write_biomass

    return write_biomass(folder, shape=SHAPE, faraday=np.radians(faraday_deg()), noise=10 ** (noise_db() / 10),
                         rfi_percent=RFI_PERCENT)


if __name__ == "__main__":
    print(write())
