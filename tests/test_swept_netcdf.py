"""results.nc of a map sweep written by its swept cells (issue 24, Speed): a map variable held as its cases
(``SweptCells``) reads as the dense grid, and results.nc, written by the chunks that hold a case only, reads back
bit for bit as xarray's own writing of the dense dataset."""

import h5py
import numpy as np
import pytest
import xarray as xr

import e2esim.io.swept_netcdf as swept_netcdf
from e2esim.maps.netcdf import CHANGE_ATTRS, DIMS, STATE_ATTRS, cell_states, write_map_netcdf
from e2esim.maps.swept_cells import SweptCells

SHAPE = (2, 1, 3, 7, 9)


def _cells(rng):
    """Cases on some cells of a (2, 1, 3, 7, 9) grid, none in the chunk of the last rows' first columns."""
    lat, lon = np.nonzero(rng.random(SHAPE[3:]) < 0.3)
    keep = ~((lat >= 4) & (lon < 4))
    lat, lon = lat[keep], lon[keep]
    index = tuple(np.repeat(a, SHAPE[2]) for a in (lat, lon))
    month = np.tile(np.arange(SHAPE[2]), lat.size)
    index = tuple(np.concatenate([a, a]) for a in (np.zeros_like(month), np.zeros_like(month), month, *index))
    index = (np.r_[np.zeros(month.size, int), np.ones(month.size, int)], *index[1:])
    return index


def test_swept_cells_are_the_dense_grid(rng):
    index = _cells(rng)
    values = rng.normal(size=index[0].size)
    values[::7] = np.nan
    mask = np.zeros(SHAPE[3:], bool)
    mask[6, 0] = True
    cells = SweptCells(SHAPE, index, values, np.nan, (mask, -5.0))
    dense = np.full(SHAPE, np.nan)
    dense[index] = values
    dense[..., mask] = -5.0
    np.testing.assert_array_equal(np.asarray(cells), dense)
    np.testing.assert_array_equal(cells[1, 0, 2], dense[1, 0, 2])
    assert np.nansum(cells) == np.nansum(dense) and cells.astype(np.float32).dtype == np.float32
    passed = SweptCells(SHAPE, index, (values > 0).astype(float), np.nan)
    state = SweptCells(SHAPE, index, np.where(np.isnan(values), 2, values > 0).astype(np.int8), -1, (mask, 3))
    has_case = np.zeros(SHAPE, bool)
    has_case[index] = True
    expected = cell_states(np.where(np.isnan(dense), np.nan, np.asarray(passed)), has_case, mask)
    np.testing.assert_array_equal(np.asarray(state)[has_case | mask], expected[has_case | mask])


@pytest.mark.parametrize("chunk_cells", [4, 30])
def test_results_nc_by_swept_chunks_reads_back_as_the_dense_write(tmp_path, rng, monkeypatch, chunk_cells):
    """Edge chunks (7 x 9 cells in chunks of 4) are padded; a chunk without a case is never stored and reads back as
    the fill value (NaN, the state's -1, the change's -2)."""
    monkeypatch.setattr(swept_netcdf, "CHUNK_CELLS", chunk_cells)
    index = _cells(rng)
    values = rng.normal(size=index[0].size)
    values[::5] = np.nan
    mask = np.zeros(SHAPE[3:], bool)
    mask[0, 8] = True
    change = np.where(np.isnan(values), -2, np.sign(values)).astype(np.int8)
    data = {"agb_error": SweptCells(SHAPE, index, values, np.nan),
            "requirement0_state": SweptCells(SHAPE, index, (values > 0).astype(np.int8), -1, (mask, 3)),
            "requirement0_changed_by_rfi": SweptCells(SHAPE, index, change, -2)}
    attrs = {"agb_error": {"units": "t ha-1", "flag_values": np.array([0.0, 1.0])},
             "requirement0_state": STATE_ATTRS, "requirement0_changed_by_rfi": CHANGE_ATTRS}
    coords = {"solar": ("solar", np.array(["min", "max"], dtype=object)), "pass": ("pass", np.array(["dawn"], object)),
              "month": ("month", np.array([1, 4, 7], np.int32)), "lat": ("lat", np.arange(7.0)),
              "lon": ("lon", np.arange(9.0)), "f107": ("solar", np.array([70.0, 180.0]))}
    swept = xr.Dataset({k: xr.Variable(DIMS, v, attrs=attrs[k]) for k, v in data.items()}, coords=coords,
                       attrs={"title": "a map"})
    dense = swept.copy(data={k: np.asarray(v) for k, v in data.items()})
    write_map_netcdf(swept, tmp_path / "swept.nc")
    encoding = {k: {"zlib": True, "complevel": 1, "shuffle": False} for k in data}
    dense.to_netcdf(tmp_path / "dense.nc", engine="netcdf4", encoding=encoding)
    for decode in (True, False):
        with xr.open_dataset(tmp_path / "swept.nc", decode_cf=decode, mask_and_scale=decode) as a, \
                xr.open_dataset(tmp_path / "dense.nc", decode_cf=decode, mask_and_scale=decode) as b:
            assert list(a.variables) == list(b.variables) and a.attrs == b.attrs
            for k in b.variables:
                assert a[k].dtype == b[k].dtype and a[k].dims == b[k].dims and str(a[k].attrs) == str(b[k].attrs)
                x, y = a[k].values, b[k].values
                assert x.tobytes() == y.tobytes() if x.dtype != object else x.tolist() == y.tolist()
                drop = ("chunksizes", "source", "preferred_chunks")
                assert str({e: v for e, v in a[k].encoding.items() if e not in drop}) == \
                    str({e: v for e, v in b[k].encoding.items() if e not in drop})  # NaN fill values: as text
    with h5py.File(tmp_path / "swept.nc", "r") as f:
        chunk = f["agb_error"].chunks
        assert chunk == (2, 1, 3, min(7, chunk_cells), min(9, chunk_cells))
        stored = f["agb_error"].id.get_num_chunks()
        assert stored == len(data["agb_error"].occupied_chunks(chunk))
        if chunk_cells == 4:
            assert stored < 6  # of 2 x 3 chunks, the one of rows 4-6, columns 0-3 holds no case
