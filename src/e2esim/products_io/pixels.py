"""What a product reader hands on: the product's grid, what it holds per pixel (a block of rows at a time, so that
memory does not grow with the grid) and the facts it states once (which corrections were applied), and the error
every reader raises for a file whose layout or values are not the ones it knows."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from e2esim.errors import UserError


class ProductFileError(UserError):
    """A product file e2esim cannot use (truncated, a group or variable missing or unexpected, wrong units, a value
    out of range): the message names the file, the group or variable, the value and what is allowed; exit 2."""


@dataclass(frozen=True)
class PixelBlock:
    """Rows ``rows`` (a slice) of the product's grid; every array has shape (n_rows, n_columns).

    sigma : (sigma_hh, sigma_hv, sigma_vv) in m^2/m^2, or None where the product holds no backscatter (then the
    scenario's scene is assumed). hhvv : complex <S_hh S_vv*> (m^2/m^2) or None. looks : independent looks of the
    product's covariance estimate, or None. noise_power : sigma_n per channel (linear NESZ). faraday_mean,
    faraday_sd : the one-way Faraday rotation in the data (rad) and the SD of its estimate (rad; NaN where the
    product left it empty), or None where the product holds no Faraday-rotation layer. valid : pixels with data.
    crosstalk_corrected : whether the processor corrected crosstalk at each pixel (a NISAR RSLC's tables along slant
    range), or None where the product's one flag (``ProductPixels.crosstalk_applied``) holds for every pixel.
    """

    rows: slice
    valid: np.ndarray
    noise_power: np.ndarray
    sigma: tuple | None = None
    hhvv: np.ndarray | None = None
    looks: np.ndarray | None = None
    faraday_mean: np.ndarray | None = None
    faraday_sd: np.ndarray | None = None
    crosstalk_corrected: np.ndarray | None = None


@dataclass(frozen=True)
class ProductPixels:
    """A product opened for the uncertainty product.

    mission : "biomass" or "nisar". shape : (rows, columns) of the output grid. coordinates : {name: (dims,
    values, attributes)} of the grid, written to the outputs as they are. read : rows -> ``PixelBlock``.
    faraday_applied : whether the processor corrected Faraday rotation. crosstalk_applied : whether it corrected
    crosstalk (non-zero crosstalk values in the product). facts : {name: value} of what was read once (flags, RFI
    fractions, crosstalk magnitudes), written into the outputs' attributes. frequency_hz : the radar frequency.
    geotransform : (x0, dx, y0, dy) of a map grid (GeoTIFF), None for a radar grid. crs : its EPSG code or None.
    rfi_blanked_fraction : the share f_t of the aperture time the processor's RFI mitigation removed (BIOMASS: the
    largest ``percentageAffectedLines`` over the polarisations; NISAR: the largest ``rfiLikelihood``), counted as
    the gain loss 1 - f_t of the ``rfi`` error term (``FixedGain``: not restored by the processor;
    docs/theory/rfi.md).
    """

    path: str
    mission: str
    shape: tuple
    coordinates: dict
    read: Callable[[slice], PixelBlock]
    faraday_applied: bool
    crosstalk_applied: bool
    facts: dict = field(default_factory=dict)
    geotransform: tuple | None = None
    crs: int | None = None
    rfi_blanked_fraction: float = 0.0


def check_units(path, variable: str, found, expected) -> None:
    """Refuse a variable whose units attribute is not the one the layout gives (``expected`` None: no attribute)."""
    if isinstance(found, bytes):
        found = found.decode("utf-8", "replace")
    if found != expected:
        allowed = "no units attribute" if expected is None else f"units {expected!r}"
        raise ProductFileError(f"{path}: {variable}: units {found!r}; the layout has {allowed}")


def check_shape(path, variable: str, found: tuple, expected: tuple) -> None:
    if tuple(found) != tuple(expected):
        raise ProductFileError(f"{path}: {variable}: shape {tuple(found)}; expected {tuple(expected)} (the grid)")
