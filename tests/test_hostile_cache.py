"""The climatology cache as a hostile or broken place (issue 22, item 8): a folder that cannot be read or written,
a missing home folder, a planted table with altered numbers, special files and crafted HDF5 files. The cache is
optional: the run goes on with a warning and the numbers of a computation without cache."""

import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from e2esim.faraday.climatology import site_path_integrals
from e2esim.io import array_cache
from e2esim.io.array_cache import MAX_CACHE_FILE_BYTES, ArrayCache, CacheWarning, open_cache, read_checked
from e2esim.ionosphere.slant import SlantSettings
from e2esim.orbit.modules import BiomassOrbit

ROOT = Path(__file__).resolve().parents[1]
SITE = {"name": "boreal", "lat_deg": 60.0, "lon_deg": 92.0}
FEW_DATES = {"start": "2026-02-01", "end": "2026-11-30", "step_days": 90}
SETTINGS = SlantSettings("thin_shell")


@pytest.fixture(autouse=True)
def fresh_warnings(monkeypatch):
    """Each test sees the warnings of its own folders (the cache says a folder's problem once per process)."""
    monkeypatch.setattr(array_cache, "_warned", set(), raising=False)


@pytest.fixture(scope="module")
def geometry():
    return BiomassOrbit(site=SITE, swath_samples=2, acquisitions=FEW_DATES).geometry


@pytest.fixture(scope="module")
def reference(geometry):
    return site_path_integrals(geometry, [70.0], SETTINGS, None)


def _unusable_folder(kind: str, tmp_path: Path) -> Path:
    if kind == "a file":
        (tmp_path / "file").write_text("not a folder")
        return tmp_path / "file"
    if kind == "/dev/null":
        return Path("/dev/null")
    if kind == "below /proc":  # cannot be created, even by root
        return Path("/proc/e2esim-no-such-folder/cache")
    if kind == "a name too long":
        return tmp_path / ("x" * 300)
    folder = tmp_path / "read-only"
    folder.mkdir()
    folder.chmod(0o555)
    return folder


@pytest.mark.parametrize("kind", ["a file", "/dev/null", "below /proc", "a name too long", "read-only"])
def test_a_cache_folder_that_cannot_be_written_never_stops_the_computation(tmp_path, geometry, reference, kind):
    """Used to crash after the climatology was computed (FileExistsError, PermissionError, ENAMETOOLONG)."""
    if kind == "read-only" and os.geteuid() == 0:
        pytest.skip("root writes into read-only folders")
    folder = _unusable_folder(kind, tmp_path)
    with pytest.warns(CacheWarning, match=r"climatology cache: cannot (write|read) in the cache folder .*; the "):
        got = site_path_integrals(geometry, [70.0], SETTINGS, ArrayCache(folder))
    assert np.array_equal(got.faraday, reference.faraday) and np.array_equal(got.stec, reference.stec)


def test_a_folder_problem_is_said_once_not_once_per_table(tmp_path, geometry):
    (tmp_path / "file").write_text("")
    with pytest.warns(CacheWarning) as record:
        for f107 in (70.0, 180.0):
            site_path_integrals(geometry, [f107], SETTINGS, ArrayCache(tmp_path / "file"))
    assert len(record) == 1 and "(File exists)" in str(record[0].message)


def test_no_home_folder_means_no_cache_not_a_crash(monkeypatch):
    """Path.home() raises RuntimeError when HOME is unset and the user has no passwd entry."""
    monkeypatch.delenv("E2ESIM_CACHE", raising=False)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)

    def no_home():
        raise RuntimeError("Could not determine home directory.")

    monkeypatch.setattr(Path, "home", no_home)
    with pytest.warns(CacheWarning, match=r"no cache folder \(RuntimeError: Could not determine home directory.\); "
                                          "the climatology is computed without a cache"):
        assert open_cache(None) is None
    assert open_cache("off") is None


def test_a_run_with_an_unusable_cache_finishes_with_a_one_line_warning(tmp_path):
    scenario = tmp_path / "s.yaml"
    scenario.write_text(f"orbit: {{type: biomass_orbit, swath_samples: 2, site: {SITE}, acquisitions: {FEW_DATES}}}\n"
                        "scene: {type: table1_forest}\ninstrument: {type: biomass}\n"
                        "ionosphere: {type: iri_climatology, method: thin_shell}\n"
                        "propagation: {type: hv_backscatter_error}\n")
    env = {**os.environ, "E2ESIM_CACHE": "/dev/null"}
    proc = subprocess.run([sys.executable, "-m", "e2esim", "run", str(scenario), "-o", str(tmp_path / "run"),
                           "--no-progress"], capture_output=True, text=True, env=env, cwd=tmp_path, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert ("e2esim: warning: climatology cache: cannot write in the cache folder /dev/null (File exists); the run "
            "goes on without caching there") in proc.stderr
    assert "Traceback" not in proc.stderr and (tmp_path / "run" / "results.h5").exists()


def _cached_file(folder: Path, geometry) -> Path:
    site_path_integrals(geometry, [70.0], SETTINGS, ArrayCache(folder))
    (path,) = folder.iterdir()
    return path


def test_a_planted_table_with_altered_numbers_is_recomputed_with_a_warning(tmp_path, geometry, reference):
    """Used to be read back and used without a word."""
    path = _cached_file(tmp_path, geometry)
    with h5py.File(path, "r+") as f:
        f["faraday"][...] = 2.0 * f["faraday"][()]
    with pytest.warns(CacheWarning, match=r"ignoring .*faraday_site_.*\.h5 \(its numbers do not match their "
                                          r"checksum \(altered or damaged\)\); the table is recomputed"):
        got = site_path_integrals(geometry, [70.0], SETTINGS, ArrayCache(tmp_path))
    assert np.array_equal(got.faraday, reference.faraday)
    again = site_path_integrals(geometry, [70.0], SETTINGS, ArrayCache(tmp_path))  # overwritten: silent again
    assert np.array_equal(again.faraday, reference.faraday)


def test_a_table_copied_under_another_key_is_refused(tmp_path, geometry):
    path = _cached_file(tmp_path, geometry)
    os.replace(path, tmp_path / "faraday_site_000000000000000000000000.h5")
    stored, why = read_checked(tmp_path / "faraday_site_000000000000000000000000.h5")
    assert stored is None and "renamed or copied from elsewhere" in why


def test_a_cache_file_carries_its_checksum_and_producer(tmp_path, geometry):
    import e2esim

    attrs = dict(read_checked(_cached_file(tmp_path, geometry))[0]["attrs"])
    assert len(attrs["checksum"]) == 64 and attrs["cache_schema"] == array_cache.SCHEMA_VERSION == 2
    assert attrs["e2esim_version"] == e2esim.__version__ and attrs["pyiri_version"]


def test_a_fifo_in_the_cache_is_not_opened(tmp_path):
    """A FIFO under a cache file's name blocked the run for ever (h5py waits for a writer)."""
    code = f"""
import warnings
from e2esim.faraday.climatology import site_path_integrals
from e2esim.io.array_cache import ArrayCache, cache_file, cache_key
from e2esim.ionosphere.slant import SlantSettings
from e2esim.orbit.modules import BiomassOrbit
import os
geo = BiomassOrbit(site={SITE!r}, swath_samples=2, acquisitions={FEW_DATES!r}).geometry
cache = ArrayCache({str(tmp_path)!r})
real = cache._path
def planted(*args):
    path = real(*args)
    if not path.exists():
        os.mkfifo(path)
    return path
cache._path = planted
with warnings.catch_warnings(record=True) as seen:
    warnings.simplefilter("always")
    site_path_integrals(geo, [70.0], SlantSettings("thin_shell"), cache)
print(seen[0].message)
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "it is a FIFO (named pipe), not a file of this cache; the table is recomputed" in proc.stdout


def _file_with(tmp_path, build) -> Path:
    path = tmp_path / "faraday_site_planted.h5"
    with h5py.File(path, "w") as f:
        build(f)
    return path


def test_crafted_cache_files_are_refused_before_any_array_is_read(tmp_path):
    secret = tmp_path / "secret.bin"
    secret.write_bytes(b"private bytes" * 8)
    external = _file_with(tmp_path, lambda f: f.create_dataset("vtec", shape=(104,), dtype="u1",
                                                               external=[(str(secret), 0, 104)]))
    assert read_checked(external, ("vtec",)) == (None, "'vtec' keeps its data outside the file")

    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["vtec"] = np.ones(3)
    linked = _file_with(tmp_path, lambda f: f.__setitem__("vtec", h5py.ExternalLink(str(other), "vtec")))
    assert read_checked(linked, ("vtec",)) == (None, "'vtec' is a link (links are never followed)")

    def bomb(f):  # 8 TiB declared, a few kB on disk: reading it would allocate all of it
        f.create_dataset("vtec", shape=(2**40,), dtype="f8", chunks=(2**20,), fillvalue=1.0)

    stored, why = read_checked(_file_with(tmp_path, bomb), ("vtec",))
    assert stored is None and why == (f"its arrays would take {2**43:,} bytes, above the limit of "
                                      f"{MAX_CACHE_FILE_BYTES:,}")


def test_a_cache_file_without_a_checksum_is_a_miss(tmp_path):
    path = _file_with(tmp_path, lambda f: f.create_dataset("vtec", data=np.ones(3)))
    assert read_checked(path, ("vtec",)) == (None, "it carries no checksum (not written by this version of e2esim)")


def test_a_file_size_limit_while_a_table_is_cached_is_a_warning_not_a_crash(tmp_path):
    """The cache's HDF5 writes go through e2esim.io.guarded_h5 like results.h5: a full disk or the file-size limit
    inside HDF5 is a warning and the run goes on; writing with h5py directly, a failed flush inside HDF5 could end
    the process with a segmentation fault at exit (issue 22, item 3)."""
    import subprocess
    import sys

    code = f"""
import resource, warnings
import numpy as np
from e2esim.io.array_cache import ArrayCache
resource.setrlimit(resource.RLIMIT_FSIZE, (20_000, resource.getrlimit(resource.RLIMIT_FSIZE)[1]))
cache = ArrayCache({str(tmp_path / "cache")!r})
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    cache.put("table", {{"what": "test"}}, None, {{"x": np.random.default_rng(1).normal(size=200_000)}}, {{}})
print("warned:", [str(w.message) for w in caught])
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, (proc.returncode, proc.stderr[-2000:])
    assert "warned:" in proc.stdout and "climatology cache" in proc.stdout, proc.stdout
    assert "Traceback" not in proc.stderr
    assert not list((tmp_path / "cache").glob("*.h5"))  # no half-written table left behind
