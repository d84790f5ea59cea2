"""Orbit state vectors from an ESA Earth Observation CFI orbit file (``Earth_Observation_File`` XML).

The layout is that of the EO CFI orbit files (ESA, "Earth Observation Mission CFI Software: Mission Conventions
Document" and "File Format Standard", EOP-GFS; the Sentinel-1 precise orbit product AUX_POEORB and the BIOMASS
and Sentinel-2 ``MPL_ORBPRE``/``AUX_*ORB`` files follow it; older files name the root ``Earth_Explorer_File``)::

    <Earth_Observation_File>
      <Earth_Observation_Header> ... <Variable_Header><Ref_Frame>EARTH_FIXED</Ref_Frame>
                                                      <Time_Reference>UTC</Time_Reference> ...
      <Data_Block type="xml">
        <List_of_OSVs count="N">
          <OSV>
            <TAI>TAI=2026-05-01T05:59:23.000000</TAI> <UTC>UTC=2026-05-01T05:58:46.000000</UTC>
            <UT1>UT1=2026-05-01T05:58:46.012345</UT1> <Absolute_Orbit>+1234</Absolute_Orbit>
            <X unit="m">...</X> <Y unit="m">...</Y> <Z unit="m">...</Z>
            <VX unit="m/s">...</VX> <VY unit="m/s">...</VY> <VZ unit="m/s">...</VZ>
            <Quality>NOMINAL</Quality>
          </OSV> ...

Positions and velocities are Earth-fixed (``EARTH_FIXED``, the ITRF realisation of the orbit determination);
e2esim reads the ``UTC`` time of each vector (TAI and UT1 are not needed: the Earth-fixed vectors already carry
the Earth's orientation). A ``Ref_Frame`` other than EARTH_FIXED, a unit other than m and m/s, a ``count`` that
disagrees with the vectors present, a truncated file or a document type declaration (entities are never expanded)
is refused with a message naming the file and the element.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.input_files import open_regular, read_limited
from e2esim.orbit.real.trajectory import StateVectorTrajectory, check_state_vectors

MAX_ORBIT_FILE_BYTES = 200_000_000
"""Largest orbit file read (200 MB: a Sentinel-1 precise orbit of 26 h at 10 s is about 4.5 MB)."""

ROOTS = ("Earth_Observation_File", "Earth_Explorer_File")
POSITION_KEYS = ("X", "Y", "Z")
VELOCITY_KEYS = ("VX", "VY", "VZ")


def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1]


def _child(node, name: str):
    return next((c for c in node if _local(c.tag) == name), None)


def file_head(path, what: str, count: int = 8) -> bytes:
    """The first ``count`` bytes of the regular file ``path`` (a FIFO or folder refused, never waited on)."""
    fd = open_regular(path, what, PhysicsInputError)
    try:
        return read_limited(fd, count)
    finally:
        os.close(fd)


def read_file_bytes(path, what: str) -> bytes:
    """The bytes of the regular file ``path`` (at most ``MAX_ORBIT_FILE_BYTES``), errors naming ``what``."""
    fd = open_regular(path, what, PhysicsInputError)
    try:
        size = os.fstat(fd).st_size
        if size > MAX_ORBIT_FILE_BYTES:
            raise PhysicsInputError(f"{path}: the {what} holds {size:,} bytes; at most {MAX_ORBIT_FILE_BYTES:,} "
                                    "are read")
        return read_limited(fd, size)
    finally:
        os.close(fd)


def read_eocfi_orbit(path) -> StateVectorTrajectory:
    """The state vectors of an EO CFI orbit file as an interpolated trajectory (module docstring)."""
    data = read_file_bytes(path, "EO CFI orbit file")
    if b"<!DOCTYPE" in data or b"<!ENTITY" in data:
        raise PhysicsInputError(f"{path}: the EO CFI orbit file has a document type declaration; an EO CFI file has "
                                "none, and e2esim does not expand XML entities")
    try:
        root = ET.fromstring(data)
    except ET.ParseError as exc:
        raise PhysicsInputError(f"{path}: not a complete XML document ({exc}); the file is truncated or is not an "
                                "EO CFI orbit file") from exc
    if _local(root.tag) not in ROOTS:
        raise PhysicsInputError(f"{path}: the root element is <{_local(root.tag)}>; an EO CFI orbit file has "
                                f"<{ROOTS[0]}> (or the older <{ROOTS[1]}>)")
    frame = root.find(".//{*}Variable_Header/{*}Ref_Frame")
    if frame is not None and (frame.text or "").strip() != "EARTH_FIXED":
        raise PhysicsInputError(f"{path}: Earth_Observation_Header/Variable_Header/Ref_Frame is "
                                f"{(frame.text or '').strip()!r}; e2esim reads EARTH_FIXED state vectors")
    block = _child(root, "Data_Block")
    osv_list = None if block is None else _child(block, "List_of_OSVs")
    if osv_list is None:
        raise PhysicsInputError(f"{path}: no Data_Block/List_of_OSVs element; an EO CFI orbit file lists its state "
                                "vectors there")
    osvs = [c for c in osv_list if _local(c.tag) == "OSV"]
    count = osv_list.get("count")
    if count is not None and count.strip().lstrip("+").isdigit() and int(count) != len(osvs):
        raise PhysicsInputError(f"{path}: Data_Block/List_of_OSVs declares count={count.strip()} but holds "
                                f"{len(osvs)} OSV elements (a truncated or edited file)")
    times, pos, vel = [], np.zeros((len(osvs), 3)), np.zeros((len(osvs), 3))
    for i, osv in enumerate(osvs):
        where = f"Data_Block/List_of_OSVs/OSV[{i}]"
        times.append(_utc(path, osv, where))
        for keys, unit, out in ((POSITION_KEYS, "m", pos), (VELOCITY_KEYS, "m/s", vel)):
            for k, key in enumerate(keys):
                out[i, k] = _number(path, osv, key, unit, where)
    t = np.array(times, "datetime64[ns]")
    if t.size == 0:
        raise PhysicsInputError(f"{path}: Data_Block/List_of_OSVs holds no OSV element")
    epoch = t[0]
    t_s = (t - epoch) / np.timedelta64(1, "s")
    check_state_vectors(str(path), t_s, pos, vel, where="OSV")
    return StateVectorTrajectory(source=str(path), kind="EO CFI state vectors", epoch=epoch, start_s=float(t_s[0]),
                                 end_s=float(t_s[-1]), t_s=t_s, position=pos, velocity=vel)


def _utc(path, osv, where: str) -> np.datetime64:
    node = _child(osv, "UTC")
    text = "" if node is None else (node.text or "").strip()
    if not text.startswith("UTC="):
        raise PhysicsInputError(f"{path}: {where}/UTC is {text!r}; expected UTC=YYYY-MM-DDThh:mm:ss[.ffffff]")
    try:
        return np.datetime64(text[4:], "ns")
    except ValueError as exc:
        raise PhysicsInputError(f"{path}: {where}/UTC is {text!r}; expected UTC=YYYY-MM-DDThh:mm:ss[.ffffff]") from exc


def _number(path, osv, key: str, unit: str, where: str) -> float:
    node = _child(osv, key)
    if node is None:
        raise PhysicsInputError(f"{path}: {where} has no {key} element; an OSV has X, Y, Z (m) and VX, VY, VZ (m/s)")
    given = node.get("unit")
    if given is not None and given.strip() != unit:
        raise PhysicsInputError(f"{path}: {where}/{key} has unit={given!r}; expected unit=\"{unit}\"")
    try:
        value = float((node.text or "").strip())
    except ValueError as exc:
        raise PhysicsInputError(f"{path}: {where}/{key} is {node.text!r}, not a number") from exc
    return value
