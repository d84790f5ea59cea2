"""Writers of small orbit files for the tests (readers are in e2esim.orbit.real): an EO CFI state-vector file, a
NISAR orbit group and a TLE, and the circular orbit's own trajectory through a site's imaging instant."""

from __future__ import annotations

import datetime as dt

import h5py
import numpy as np

from e2esim.orbit.frames import EARTH_ROTATION_RATE
from e2esim.orbit.geometry import view_geometry
from e2esim.orbit.real.tle import tle_checksum
from e2esim.orbit.sunsync import SunSynchronousOrbit, orbit_state


def circular_trajectory(orbit: SunSynchronousOrbit, lat_deg, lon_deg, incidence_deg, pass_name, date="2026-05-01",
                        before_s=1800.0, after_s=1800.0, step_s=60.0):
    """The circular orbit's Earth-fixed trajectory through the instant it images the site at ``incidence_deg``
    (e2esim.orbit.geometry.view_geometry), node longitude turning at -omega_E: (UTC times datetime64[ns],
    positions, velocities, the view geometry). The imaging instant is on ``date`` at the UTC of the circular
    model's local time there, so that local mean solar time = UTC + lon / 15 agrees with it."""
    g = view_geometry(orbit, np.radians(lat_deg), np.radians(lon_deg), np.radians(incidence_deg), pass_name)
    ut_h = float(g.local_time_h) - lon_deg / 15.0  # before 0: the UTC day before the local date
    t0 = np.datetime64(date, "ns") + np.timedelta64(round(ut_h * 3600e6) * 1000, "ns")  # whole us, as EO CFI writes
    t = np.arange(-before_s, after_s + step_s / 2, step_s)
    r, v = orbit_state(orbit, float(g.u) + orbit.mean_motion * t, float(g.node_lon) - EARTH_ROTATION_RATE * t)
    return t0 + (t * 1e9).astype("int64").astype("timedelta64[ns]"), r, v, g


def eocfi_text(times, r, v, position_unit="m", velocity_unit="m/s", count=None, frame="EARTH_FIXED") -> str:
    """An EO CFI orbit file (``Earth_Observation_File``, e2esim.orbit.real.eocfi) of the state vectors."""
    def utc(x):
        return np.datetime_as_string(x, unit="us")

    osvs = []
    for i, (ti, ri, vi) in enumerate(zip(times, r, v)):
        xyz = "".join(f'<{k} unit="{position_unit}">{x:.3f}</{k}>' for k, x in zip("XYZ", ri))
        vxyz = "".join(f'<{k} unit="{velocity_unit}">{x:.6f}</{k}>' for k, x in zip(("VX", "VY", "VZ"), vi))
        osvs.append(f"<OSV><TAI>TAI={utc(ti + np.timedelta64(37, 's'))}</TAI><UTC>UTC={utc(ti)}</UTC>"
                    f"<UT1>UT1={utc(ti)}</UT1><Absolute_Orbit>+{1000 + i // 90}</Absolute_Orbit>{xyz}{vxyz}"
                    "<Quality>NOMINAL</Quality></OSV>")
    n = len(osvs) if count is None else count
    return ('<?xml version="1.0" encoding="UTF-8"?>\n<Earth_Observation_File xmlns="http://eop-cfi.esa.int/CFI">'
            "<Earth_Observation_Header><Fixed_Header><File_Name>BIO_TEST_AUX_ORBRES</File_Name>"
            "<File_Description>test orbit from e2esim's circular model</File_Description><Mission>BIOMASS</Mission>"
            f"<File_Class>TEST</File_Class><File_Type>AUX_ORBRES</File_Type><Validity_Period><Validity_Start>"
            f"UTC={utc(times[0])}</Validity_Start><Validity_Stop>UTC={utc(times[-1])}</Validity_Stop>"
            "</Validity_Period></Fixed_Header><Variable_Header><Ref_Frame>" + frame + "</Ref_Frame>"
            "<Time_Reference>UTC</Time_Reference></Variable_Header></Earth_Observation_Header>"
            f'<Data_Block type="xml"><List_of_OSVs count="{n}">\n' + "\n".join(osvs)
            + "\n</List_of_OSVs></Data_Block></Earth_Observation_File>\n")


def write_nisar_orbit(path, times, r, v, group="/science/LSAR/GCOV/metadata/orbit", time_units=None,
                      position_units="meters"):
    """A NISAR product's orbit group (e2esim.orbit.real.nisar) holding the state vectors."""
    epoch = times[0].astype("datetime64[D]")
    t = (times - epoch) / np.timedelta64(1, "s")
    with h5py.File(path, "w") as f:
        g = f.require_group(group)
        g.create_dataset("time", data=t).attrs["units"] = time_units or f"seconds since {epoch}T00:00:00"
        g.create_dataset("position", data=r).attrs["units"] = position_units
        g.create_dataset("velocity", data=v).attrs["units"] = "meters per second"
        g.create_dataset("orbitType", data="POE")
        g.create_dataset("interpMethod", data="Hermite")


def tle_lines(epoch: dt.datetime, inclination_deg, raan_deg, ecc, argp_deg, mean_anomaly_deg, revs_per_day,
              number=99999, bstar="00000-0") -> tuple:
    """The two lines of a TLE of these mean elements (checksums computed)."""
    doy = (epoch - dt.datetime(epoch.year, 1, 1)).total_seconds() / 86400.0 + 1.0
    l1 = (f"1 {number:05d}U 26001A   {epoch.year % 100:02d}{doy:012.8f}  .00000000  00000-0  {bstar} 0  999")
    l2 = (f"2 {number:05d} {inclination_deg:8.4f} {raan_deg:8.4f} {round(ecc * 1e7):07d} {argp_deg:8.4f} "
          f"{mean_anomaly_deg:8.4f} {revs_per_day:11.8f}    1")
    return l1 + str(tle_checksum(l1 + "0")), l2 + str(tle_checksum(l2 + "0"))
