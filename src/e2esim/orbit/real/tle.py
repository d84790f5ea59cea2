"""An orbit from a two-line element set (TLE), propagated with SGP4 (the ``sgp4`` package, optional extra
``orbits``) and rotated from TEME into Earth-fixed axes.

SGP4 (Hoots & Roehrich 1980, Spacetrack Report #3, as revised by Vallado, Crawford, Hujsak & Kelso 2006,
"Revisiting Spacetrack Report #3", AIAA 2006-6753) gives position and velocity in the True Equator Mean Equinox
frame (TEME) with the WGS72 constants the element sets are fitted with. Earth-fixed (pseudo Earth-fixed, PEF)
axes follow by a rotation about z by the Greenwich mean sidereal time (Vallado et al. 2006, Section "TEME";
Vallado 2013, Fundamentals of Astrodynamics, eq. 3-47 for GMST, IAU 1982):

    r_ef = R3(theta_GMST) r_TEME,   v_ef = R3(theta_GMST) v_TEME - omega_E z x r_ef,

    theta_GMST = 67310.54841 s + (876600 h + 8640184.812866 s) T + 0.093104 s T^2 - 6.2e-6 s T^3,
    T = (JD(UT1) - 2451545.0) / 36525.

UT1 is taken equal to UTC (|UT1 - UTC| < 0.9 s, at most about 0.45 km along the Earth's rotation at the site's
latitude) and polar motion (about 0.3 arcsec, 10 m) is left out: both far below SGP4's own error, about 1 km at
the element set's epoch growing by 1 to 3 km a day in low Earth orbit (Vallado et al. 2006, Section I). An
element set is therefore used only within ``TLE_SPAN_DAYS`` of its epoch.

The checksum of each line (the last column: the sum of its digits, each minus sign counting 1, modulo 10) is
checked before SGP4 sees the lines.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.extras import optional_import
from e2esim.orbit.frames import EARTH_ROTATION_RATE
from e2esim.orbit.real.eocfi import read_file_bytes
from e2esim.orbit.real.trajectory import Trajectory

TLE_SPAN_DAYS = 7.0
"""Days either side of an element set's epoch in which it is propagated (SGP4 error of order 10 km by then)."""

J2000_JD = 2451545.0
SGP4_ERRORS = {1: "mean eccentricity outside [0, 1) or mean motion below 0", 2: "mean motion below 0",
               3: "perturbed eccentricity outside [0, 1]", 4: "semi-latus rectum below 0",
               5: "epoch elements are sub-orbital", 6: "the satellite has decayed"}


def tle_checksum(line: str) -> int:
    """Checksum of a TLE line: the sum of the digits of its first 68 columns, each '-' counting 1, modulo 10."""
    return sum(int(c) if c.isdigit() else (1 if c == "-" else 0) for c in line[:68]) % 10


def parse_tle(text: str, source: str) -> tuple:
    """(name, line 1, line 2) of a two- or three-line element set; refuses bad line numbers, lengths, checksums."""
    lines = [ln.rstrip() for ln in text.splitlines() if ln.strip()]
    if len(lines) == 3:
        name, lines = lines[0].strip(), lines[1:]
    else:
        name = ""
    if len(lines) != 2:
        raise PhysicsInputError(f"{source}: {len(lines)} element lines; a TLE file holds one element set: an "
                                "optional name line, then line 1 and line 2 (69 columns each)")
    for k, line in enumerate(lines, start=1):
        if len(line) != 69 or not line.startswith(f"{k} "):
            raise PhysicsInputError(f"{source}: TLE line {k} is {line[:72]!r} ({len(line)} columns); expected 69 "
                                    f"columns starting with '{k} ' (a truncated file?)")
        want = tle_checksum(line)
        if line[68] != str(want):
            raise PhysicsInputError(f"{source}: TLE line {k} has checksum {line[68]!r}, but its columns 1-68 sum to "
                                    f"{want} (mod 10): a corrupted or edited element set")
    if lines[0][2:7] != lines[1][2:7]:
        raise PhysicsInputError(f"{source}: TLE lines 1 and 2 are of different satellites ({lines[0][2:7].strip()} "
                                f"and {lines[1][2:7].strip()})")
    return name, lines[0], lines[1]


def gmst(jd_ut1) -> np.ndarray:
    """Greenwich mean sidereal time (rad) at Julian date ``jd_ut1`` (IAU 1982; Vallado 2013, eq. 3-47)."""
    t = (np.asarray(jd_ut1, float) - J2000_JD) / 36525.0
    seconds = 67310.54841 + (876600.0 * 3600.0 + 8640184.812866) * t + 0.093104 * t**2 - 6.2e-6 * t**3
    return np.mod(seconds, 86400.0) * (2 * np.pi / 86400.0)


def teme_to_earth_fixed(r_teme, v_teme, jd_ut1):
    """Earth-fixed position and Earth-relative velocity from TEME ones (module docstring); same units in and out."""
    theta = gmst(jd_ut1)
    c, s = np.cos(theta)[..., None], np.sin(theta)[..., None]
    r, v = np.asarray(r_teme, float), np.asarray(v_teme, float)
    r_ef = np.stack([c[..., 0] * r[..., 0] + s[..., 0] * r[..., 1], -s[..., 0] * r[..., 0] + c[..., 0] * r[..., 1],
                     r[..., 2]], -1)
    v_rot = np.stack([c[..., 0] * v[..., 0] + s[..., 0] * v[..., 1], -s[..., 0] * v[..., 0] + c[..., 0] * v[..., 1],
                      v[..., 2]], -1)
    omega_cross_r = EARTH_ROTATION_RATE * np.stack([-r_ef[..., 1], r_ef[..., 0], np.zeros_like(r_ef[..., 0])], -1)
    return r_ef, v_rot - omega_cross_r


@dataclass(frozen=True)
class TLETrajectory(Trajectory):
    """SGP4 propagation of one element set (``satrec``, an ``sgp4.api.Satrec``), Earth-fixed; ``epoch`` is the
    element set's epoch (UTC)."""

    satrec: object = None
    lines: tuple = ()

    def __reduce__(self):  # a Satrec does not pickle: rebuild it from the two lines (workers, the resume journal)
        return tle_trajectory, (*self.lines, self.source)

    def teme(self, t_s):
        """TEME position (m) and velocity (m/s) at ``t_s`` (s since the epoch), with the Julian dates used."""
        t = np.asarray(t_s, float)
        jd = np.full(t.size, self.satrec.jdsatepoch)
        fr = self.satrec.jdsatepochF + t.reshape(-1) / 86400.0
        err, r, v = self.satrec.sgp4_array(jd, fr)
        if np.any(err):
            code = int(err[err != 0][0])
            raise PhysicsInputError(f"{self.source}: SGP4 fails on this element set ({SGP4_ERRORS.get(code, code)})")
        shape = t.shape + (3,)
        return (r * 1e3).reshape(shape), (v * 1e3).reshape(shape), (jd + fr).reshape(t.shape)

    def state(self, t_s):
        r, v, jd = self.teme(t_s)
        return teme_to_earth_fixed(r, v, jd)


def read_tle(path) -> TLETrajectory:
    """The element set of a TLE file (two lines, or three with a name line first) as a trajectory."""
    text = read_file_bytes(path, "TLE file").decode("ascii", errors="replace")
    return tle_trajectory(*parse_tle(text, str(path))[1:], source=str(path))


def tle_trajectory(line1: str, line2: str, source: str = "TLE") -> TLETrajectory:
    api = optional_import("sgp4.api", "orbits", "propagating a two-line element set (orbit file in TLE format)")
    sat = api.Satrec.twoline2rv(line1, line2, api.WGS72)
    if sat.error:
        raise PhysicsInputError(f"{source}: SGP4 refuses the element set ({SGP4_ERRORS.get(sat.error, sat.error)})")
    day = np.datetime64("1949-12-31T00:00", "ns")  # jdsatepoch counts from JD 2433281.5 = 1949-12-31 00:00 UTC
    epoch = day + np.round(((sat.jdsatepoch - 2433281.5) + sat.jdsatepochF) * 86400e9).astype("int64").astype(
        "timedelta64[ns]")
    span = TLE_SPAN_DAYS * 86400.0
    return TLETrajectory(source=source, kind="TLE (SGP4, TEME rotated by GMST)", epoch=epoch, start_s=-span,
                         end_s=span, satrec=sat, lines=(line1, line2))
