"""Which NISAR product an HDF5 file is (``/science/LSAR/GCOV``, ``RSLC`` or ``GSLC``), opened by its reader
(``e2esim.products_io.nisar_gcov``, ``e2esim.products_io.nisar_slc``)."""

from __future__ import annotations

from e2esim.input_files import check_regular
from e2esim.products_io.nisar_gcov import gcov_pixels
from e2esim.products_io.nisar_slc import slc_pixels
from e2esim.products_io.pixels import ProductFileError, ProductPixels

READ = ("GCOV", "RSLC", "GSLC")
BAND = "/science/LSAR"


def open_nisar_product(path) -> ProductPixels:
    import h5py  # lazy: start-up time

    check_regular(path, "NISAR product", ProductFileError)
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise ProductFileError(f"{path}: cannot be read as HDF5 ({exc}); the file is truncated or not a NISAR "
                               "product") from None
    try:
        found = [p for p in READ if f"{BAND}/{p}" in f]
        if len(found) != 1:
            held = sorted(f[BAND]) if BAND in f else []
            holds = "groups " + ", ".join(f"{BAND}/{h}" for h in held) if held else f"no {BAND} group"
            raise ProductFileError(f"{path}: {holds}; e2esim reads a NISAR product with one of "
                                   f"{', '.join(BAND + '/' + p for p in READ)}")
        if found[0] == "GCOV":
            return gcov_pixels(str(path), f)
        return slc_pixels(str(path), f, found[0])
    except ProductFileError:
        f.close()
        raise
    except (OSError, KeyError) as exc:
        f.close()
        raise ProductFileError(f"{path}: cannot be read ({exc}); the file is truncated or damaged") from None
