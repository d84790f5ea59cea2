"""Orbit state vectors from the orbit group of a NISAR product (RSLC, GSLC, GCOV, ...) or an isce3 orbit file.

Layout of ``/science/LSAR/<PRODUCT>/metadata/orbit`` (NISAR L1/L2 product specifications, JPL D-102268 ff.,
"orbit" group; written and read by isce3's ``saveToH5``/``loadFromH5`` for ``isce3::core::Orbit``,
cxx/isce3/core/Serialization.h):

* ``time`` (N,) float64, seconds; attribute ``units`` = "seconds since YYYY-MM-DD[T ]hh:mm:ss[.f]", the
  reference epoch, UTC;
* ``position`` (N, 3) float64, m (``units`` "meters"), Earth-fixed (WGS84 / ITRF);
* ``velocity`` (N, 3) float64, m/s (``units`` "meters per second"), Earth-fixed;
* ``orbitType`` text: FOE, NOE, MOE, POE or Custom (forecast ... precise orbit ephemeris), reported;
* ``interpMethod`` text: "Hermite" or "Legendre" (isce3's interpolation). e2esim always interpolates with Hermite
  on 4 vectors (``trajectory``); at NISAR's 10 s spacing both methods agree to far below a millimetre, so the
  attribute changes nothing and the reader reports it.

Every read goes through ``e2esim.io.safe_h5.H5Reader`` (no external links or storage, no decompression bombs).
"""

from __future__ import annotations

import re

import h5py
import numpy as np

from e2esim.errors import PhysicsInputError, ResultsFileError
from e2esim.io.safe_h5 import H5Reader
from e2esim.orbit.real.eocfi import file_head
from e2esim.orbit.real.trajectory import StateVectorTrajectory, check_state_vectors

POSITION_UNITS = ("meters", "meter", "m")
VELOCITY_UNITS = ("meters per second", "meters / second", "meters/second", "m/s", "m s-1", "m.s-1")
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
_EPOCH = re.compile(r"^\s*seconds\s+since\s+(\d{4}-\d\d-\d\d)[T ](\d\d:\d\d:\d\d(?:\.\d+)?)\s*(?:Z|UTC)?\s*$")


def find_orbit_group(reader: H5Reader) -> str:
    """The path of the one group named ``orbit`` below a ``metadata`` group, or of the root group when it holds
    ``time``, ``position`` and ``velocity`` (an isce3 orbit file)."""
    root = reader.file
    if all(name in root for name in ("time", "position", "velocity")):
        return "/"
    found: list = []

    def visit(name, obj):
        if isinstance(obj, h5py.Group) and name.endswith("metadata/orbit"):
            found.append("/" + name)

    root.visititems(visit)
    if len(found) != 1:
        raise PhysicsInputError(f"{reader.path}: {'no' if not found else len(found)} groups named metadata/orbit "
                                f"({', '.join(found) or 'a NISAR product has /science/LSAR/<PRODUCT>/metadata/orbit'});"
                                " name the one to read with orbit.group")
    return found[0]


def read_nisar_orbit(path, group: str | None = None) -> StateVectorTrajectory:
    """The state vectors of a NISAR orbit group (module docstring) as an interpolated trajectory."""
    if not file_head(path, "NISAR orbit file").startswith(HDF5_SIGNATURE):
        raise PhysicsInputError(f"{path}: not an HDF5 file (no HDF5 signature at its start); a NISAR product is HDF5")
    try:
        with H5Reader(path, "NISAR orbit file") as r, r.guard():
            return _read(r, group)
    except ResultsFileError as exc:
        text = str(exc).replace("; a NISAR orbit file is the results.h5 of an e2esim run", " (a truncated download?)")
        raise PhysicsInputError(text) from exc


def _read(r: H5Reader, group: str | None) -> StateVectorTrajectory:
    base = (group or find_orbit_group(r)).rstrip("/")
    if group and r.get(base, h5py.Group, required=False) is None and base:
        raise PhysicsInputError(f"{r.path}: no group {base}; the orbit of a NISAR product is at "
                                "/science/LSAR/<PRODUCT>/metadata/orbit")
    ds = {}
    for name in ("time", "position", "velocity"):
        ds[name] = r.get(f"{base}/{name}", required=False)
        if ds[name] is None:
            raise PhysicsInputError(f"{r.path}: {base}/{name} is missing; a NISAR orbit group holds time, position "
                                    "and velocity")
    t = r.read(ds["time"], "f", (None,))
    pos = r.read(ds["position"], "f", (t.size, 3))
    vel = r.read(ds["velocity"], "f", (t.size, 3))
    units = r.text_attribute(ds["time"], "units") or ""
    m = _EPOCH.match(units)
    if m is None:
        raise PhysicsInputError(f"{r.path}: {base}/time has units {units!r}; expected \"seconds since "
                                "YYYY-MM-DDThh:mm:ss\" (the reference epoch, UTC)")
    epoch = np.datetime64(f"{m.group(1)}T{m.group(2)}", "ns")
    for name, allowed in (("position", POSITION_UNITS), ("velocity", VELOCITY_UNITS)):
        given = r.text_attribute(ds[name], "units")
        if given is not None and given.strip().lower() not in allowed:
            raise PhysicsInputError(f"{r.path}: {base}/{name} has units {given!r}; expected one of "
                                    f"{', '.join(repr(a) for a in allowed)}")
    check_state_vectors(str(r.path), t, pos, vel)
    kind = "NISAR orbit"
    for name in ("orbitType", "interpMethod"):
        node = r.get(f"{base}/{name}", required=False)
        if node is not None:
            text = r.read_text(node, node.shape)
            kind += f", {name} {str(np.asarray(text).reshape(-1)[0]).strip()}"
    return StateVectorTrajectory(source=str(r.path), kind=kind, epoch=epoch, start_s=float(t[0]), end_s=float(t[-1]),
                                 t_s=np.asarray(t, float), position=np.asarray(pos, float),
                                 velocity=np.asarray(vel, float))
