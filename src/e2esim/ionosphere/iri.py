"""Electron density of the International Reference Ionosphere through PyIRI, point by point.

PyIRI (Forsythe et al. 2023, Space Weather, doi:10.1029/2023SW003530; Bilitza et al. 2022, Rev. Geophys.
60) evaluates the IRI's monthly median F2, F1 and E layer parameters from the CCIR/URSI coefficient maps
and builds the electron density profile; its functions compute every universal time for every grid
point (an outer product). A satellite sees each point at its own UT, so this module runs the same
sequence of PyIRI functions as ``PyIRI.main_library.IRI_monthly_mean_par`` and ``IRI_density_1day``
with one UT per point:

1. magnetic inclination and modip from PyIRI's IGRF at 300 km (``igrf_library.inclination``, here with
   its coefficient file read once and one synthesis for all months of a call: iri_inclination.py);
2. foF2 and M(3000)F2 from the Jones-Gallet diurnal x geographic expansion (the product D U G, here
   evaluated per point; the coefficient files are read once per month, as PyIRI reads them but without
   fortranformat (``_read_map_file``), and held as floats, which also makes PyIRI's object-array matrix
   product about 10 times faster);
3. foE from the effective solar zenith angle, F1 probability and foF1, layer heights and thicknesses
   (``foE``, ``hm_IRI``, ``thickness``, ``hmF1_from_F2``, ``find_B_F1_bot``);
4. linear interpolation between the monthly medians around the day (``day_of_the_month_corr``) and in
   solar activity between IG12 = 0 and 100 (``solar_interpolation_of_dictionary``), then Nm from fo;
5. the profile by PyIRI's ``reconstruct_density_from_parameters_1level``.

One deliberate difference: PyIRI's ``Probability_F1`` normalises the F1 weight by its maximum over all
points of the call, which is the clip value 10 whenever any point is sunlit with cos(chi) >= 2/3 (every
global grid); here it is always 10, so a point's density does not depend on the other points.
tests/test_ionosphere_tec.py checks this module against ``IRI_density_1day`` on a global grid at one UT.
"""

from __future__ import annotations

import datetime as dt
import functools
import os

import numpy as np

from e2esim.ionosphere.iri_inclination import inclination
from e2esim.ionosphere.pyiri_import import import_pyiri

_F1_MULTIPLIER_MAX = 10.0  # clip value of the F1 weight in PyIRI's Probability_F1
FOF2_MODELS = ("ursi", "ccir")
_SOLAR_IG12 = np.array([0.0, 100.0])  # IG12 of the two solar levels of the CCIR/URSI maps


def _pyiri():
    PyIRI = import_pyiri()  # without PyIRI's plotting (matplotlib), also in climatology worker processes
    import PyIRI.igrf_library as igrf
    import PyIRI.main_library as ml

    return PyIRI, ml, igrf


@functools.lru_cache(maxsize=24)
def _coefficients(month: int):
    """CCIR and URSI foF2 and M(3000)F2 coefficients of a month as float arrays, shaped as PyIRI's
    ``read_ccir_ursi_coeff`` returns them (without its sporadic-E maps, which e2esim does not use)."""
    PyIRI, ml, _ = _pyiri()
    number = month + 10  # the files are numbered 11 to 22
    ccir_all = _read_map_file(os.path.join(PyIRI.coeff_dir, "CCIR", f"ccir{number}.asc"))
    ursi_all = _read_map_file(os.path.join(PyIRI.coeff_dir, "URSI", f"ursi{number}.asc"))
    if ccir_all is None or ursi_all is None:  # not the format of the files PyIRI ships: PyIRI's own reader
        ccir, ursi, m3000, _es = ml.read_ccir_ursi_coeff(month, PyIRI.coeff_dir)
        return np.asarray(ccir, float), np.asarray(ursi, float), np.asarray(m3000, float)
    orders = _expansion_orders()
    fof2_shape = (orders["nj"]["F0F2"], orders["nk"]["F0F2"], 2)
    m3000_shape = (orders["nj"]["M3000"], orders["nk"]["M3000"], 2)
    n = int(np.prod(fof2_shape))  # CCIR: foF2 then M(3000)F2; URSI: foF2 only
    return (ccir_all[:n].reshape(fof2_shape, order="F"), ursi_all[:n].reshape(fof2_shape, order="F"),
            ccir_all[n:].reshape(m3000_shape, order="F"))


_MAP_FIELD = 15  # characters per number of the CCIR/URSI files' records (1X,4E15.8)


def _read_map_file(path: str):
    """The numbers of a CCIR or URSI coefficient file in order, or None if a field is not of the form
    [-]d.dddE[+-]dd. PyIRI reads the (1X,4E15.8) records with fortranformat, which takes such a field as
    Python's ``float`` of it; so does this, without fortranformat's parsing of each record (8 times faster)."""
    values = []
    with open(path) as f:
        for line in f:
            record = line.rstrip("\n")
            for a in range(1, len(record), _MAP_FIELD):
                field = record[a:a + _MAP_FIELD]
                if "." not in field or "E" not in field:
                    return None
                values.append(float(field))
    return np.array(values)


@functools.lru_cache(maxsize=1)
def _expansion_orders():
    _, ml, _ = _pyiri()
    return ml.highest_power_of_extension()


def _global_functions(orders, nk, lon, lat, modip):
    """Jones-Gallet geographic functions G_k (nk, N): PyIRI's ``set_global_functions`` with the powers
    computed once (sin(modip)^i cos(lat)^j {cos, sin}(j lon), in PyIRI's order). tests/test_ionosphere_tec.py
    checks it equals PyIRI's."""
    sm = np.sin(np.radians(modip))
    cl = np.cos(np.radians(lat))
    imax = max(orders)
    sin_pow = [np.ones_like(sm)]
    for _ in range(1, imax):
        sin_pow.append(sin_pow[-1] * sm)
    out = np.empty((nk, lon.size))
    k = 0
    cos_pow = np.ones_like(cl)
    for j, q in enumerate(orders):
        if j:
            cos_pow = cos_pow * cl
        cj, sj = np.cos(np.radians(lon * j)), np.sin(np.radians(lon * j))
        for i in range(q):
            base = sin_pow[i] * cos_pow
            out[k] = base * cj
            k += 1
            if j:
                out[k] = base * sj
                k += 1
    return out


def _map(diurnal, coeffs, geographic):
    """Diagonal of D U G for both solar levels: sum_j D_j(t_n) (U G)_jn, shape (1, N, 2)."""
    return np.stack([np.sum(diurnal * (coeffs[:, :, s] @ geographic), 0) for s in range(2)], -1)[None]


def _inclination_date(year: int, month: int) -> float:
    """The decimal year of the IGRF field of a month's median, its 15th (PyIRI's ``IRI_monthly_mean_par``)."""
    _, ml, _ = _pyiri()
    return ml.decimal_year(dt.datetime(year, month, 15))


def monthly_parameters(year: int, month: int, ut_h, lon_deg, lat_deg, fof2_model: str = "ursi",
                       inc_deg=None) -> tuple:
    """Monthly median layer parameters at one UT per point, both solar levels (IG12 0 and 100).

    ut_h, lon_deg, lat_deg : 1-D arrays of the same length N. inc_deg : the points' magnetic inclination
    (deg) at 300 km for this month if already computed, else None. Returns (F2, F1, E) dicts of arrays of
    shape (1, N, 2), keys as PyIRI's ``IRI_monthly_mean_par``.
    """
    _, ml, igrf = _pyiri()
    ut = np.asarray(ut_h, float).ravel()
    lon = np.asarray(lon_deg, float).ravel()
    lat = np.asarray(lat_deg, float).ravel()
    inc = inclination(_inclination_date(year, month), lon, lat, 300.0) if inc_deg is None else inc_deg
    modip = igrf.inc2modip(inc, lat)
    mag_dip_lat = igrf.inc2magnetic_dip_latitude(inc)

    coef = _expansion_orders()
    d_fof2 = ml.set_diurnal_functions(coef["nj"]["F0F2"], ut)  # (nj, N)
    d_m3000 = ml.set_diurnal_functions(coef["nj"]["M3000"], ut)
    g_fof2 = _global_functions(coef["QM"]["F0F2"], coef["nk"]["F0F2"], lon, lat, modip)  # (nk, N)
    g_m3000 = _global_functions(coef["QM"]["M3000"], coef["nk"]["M3000"], lon, lat, modip)
    ccir, ursi, c_m3000 = _coefficients(month)
    fof2 = _map(d_fof2, ursi if fof2_model == "ursi" else ccir, g_fof2)  # (1, N, 2)
    m3000 = _map(d_m3000, c_m3000, g_m3000)

    solzen = _solar_zenith_deg(year, month, ut, lon, lat)
    solzen_eff = ml.solzen_effective(solzen)
    f107_levels = [ml.IG12_2_F107(ig) for ig in _SOLAR_IG12]
    foe = np.stack([ml.foE(month, solzen_eff, lat, f) for f in f107_levels], -1)[None]
    p_f1, fof1 = _probability_f1(solzen, mag_dip_lat, foe[0])
    nmf2, nmf1, nme, _ = ml.freq_to_Nm(fof2, fof1[None], foe, np.zeros_like(fof2))
    hmf2, hme, _ = ml.hm_IRI(m3000, foe, fof2, modip, _SOLAR_IG12)
    b_f2_bot, b_f2_top, b_e_bot, b_e_top, _, _ = ml.thickness(fof2, m3000, hmf2, hme, month, _SOLAR_IG12)
    hmf1 = ml.hmF1_from_F2(nmf2, nmf1, hmf2, b_f2_bot)
    b_f1_bot = ml.find_B_F1_bot(hmf1, hme, p_f1[None])
    f2 = {"Nm": nmf2, "fo": fof2, "M3000": m3000, "hm": hmf2, "B_top": b_f2_top, "B_bot": b_f2_bot}
    f1 = {"Nm": nmf1, "fo": fof1[None], "P": p_f1[None], "hm": hmf1, "B_bot": b_f1_bot}
    e = {"Nm": nme, "fo": foe, "hm": hme, "B_bot": b_e_bot, "B_top": b_e_top}
    return f2, f1, e


def _solar_zenith_deg(year, month, ut, lon, lat):
    """Solar zenith angle (deg) on the 15th of the month at each point's UT (PyIRI's ``gammaE`` uses the
    same day and truncates the UT to whole minutes)."""
    _, ml, _ = _pyiri()
    hour = np.fix(ut)
    minute = np.fix((ut - hour) * 60.0)
    jd = ml.juldat(dt.datetime(year, month, 15)) + (hour + minute / 60.0) / 24.0
    slon, slat = ml.subsolar_point(jd)
    cos_z = (np.sin(np.radians(slat)) * np.sin(np.radians(lat))
             + np.cos(np.radians(slat)) * np.cos(np.radians(lat)) * np.cos(np.radians(slon - lon)))
    return np.degrees(np.arccos(np.clip(cos_z, -1, 1)))


def _probability_f1(solzen, mag_dip_lat, foe):
    """F1 probability and foF1 (MHz), PyIRI ``Probability_F1`` (Bilitza et al. 2022) point by point.

    solzen, mag_dip_lat : (N,); foe : (N, 2). Returns arrays of shape (N, 2).
    """
    _, ml, _ = _pyiri()
    r12 = np.array([ml.IG12_2_R12(ig) for ig in _SOLAR_IG12])[None, :]
    mlat = np.abs(mag_dip_lat)[:, None]
    z = np.radians(solzen)[:, None]
    p = np.broadcast_to((0.5 + 0.5 * np.cos(z)) ** 2.36, foe.shape).copy()
    n = 0.093 + 0.0046 * mlat - 0.000054 * mlat**2 + 0.0003 * r12
    f100 = 5.348 + 0.011 * mlat - 0.00023 * mlat**2
    f0 = 4.35 + 0.0058 * mlat - 0.00012 * mlat**2
    fs = f0 + (f100 - f0) * r12 / 100.0
    arg = np.broadcast_to(np.cos(z), foe.shape)
    fof1 = np.zeros(foe.shape)
    day = arg > 0
    fof1[day] = np.broadcast_to(fs, foe.shape)[day] * arg[day] ** np.broadcast_to(n, foe.shape)[day]
    mult = np.minimum(-10.0 + 30.0 * arg, _F1_MULTIPLIER_MAX) / _F1_MULTIPLIER_MAX
    mult = np.where(mult < 0, np.nan, mult)
    fof1 = mult * fof1 + np.abs(mult - 1.0) * foe
    return p, fof1


def month_weights(dates) -> dict:
    """``{(year, month): (point indices, weights)}``: the monthly medians each day draws on, with PyIRI's
    linear interpolation between the 15ths of the months around it (``day_of_the_month_corr``).

    dates : one ``datetime.date`` per point.
    """
    _, ml, _ = _pyiri()
    table: dict = {}
    for i, d in enumerate(dates):
        t_before, t_after, fr1, fr2 = ml.day_of_the_month_corr(d.year, d.month, d.day)
        for t, w in ((t_before, fr1), (t_after, fr2)):
            if w > 0:
                idx, wts = table.setdefault((t.year, t.month), ([], []))
                idx.append(i)
                wts.append(w)
    return {k: (np.array(v[0]), np.array(v[1])) for k, v in table.items()}


def daily_parameters(dates, ut_h, lon_deg, lat_deg, f107_levels, fof2_model: str = "ursi",
                     monthly: bool = False) -> list:
    """Layer parameters at N points, one date and UT each: a list with one (F2, F1, E) triple of (1, N)
    arrays per F10.7 in ``f107_levels`` (sfu), as PyIRI's ``IRI_density_1day``: linear in time between
    the monthly medians around each day, then linear in solar activity (IG12 from F10.7).

    dates : a ``datetime.date`` or one per point. monthly : use each date's monthly median (as on the
    15th) without the interpolation between months.
    """
    _, ml, _ = _pyiri()
    ut = np.asarray(ut_h, float).ravel()
    lon = np.asarray(lon_deg, float).ravel()
    lat = np.asarray(lat_deg, float).ravel()
    n = ut.size
    if isinstance(dates, dt.date):
        dates = [dates] * n
    if monthly:
        groups: dict = {}
        for i, d in enumerate(dates):
            groups.setdefault((d.year, d.month), []).append(i)
        table = {k: (np.array(v), np.ones(len(v))) for k, v in groups.items()}
    else:
        table = month_weights(dates)
    months = sorted(table)
    all_idx = np.concatenate([table[m][0] for m in months])  # every month's points, one synthesis for all
    years = np.concatenate([np.full(table[m][0].size, _inclination_date(*m)) for m in months])
    ends = np.cumsum([table[m][0].size for m in months])[:-1]
    inc = np.split(inclination(years, lon[all_idx], lat[all_idx], 300.0), ends)
    acc = None
    for month_inc, (year, month) in zip(inc, months):
        idx, w = table[(year, month)]
        part = monthly_parameters(year, month, ut[idx], lon[idx], lat[idx], fof2_model, month_inc)
        if acc is None:
            acc = tuple({k: np.zeros((1, n, 2)) for k in d} for d in part)
        for a, p in zip(acc, part):
            for k in a:
                a[k][:, idx] += p[k] * w[None, :, None]
    f2, f1, e = acc
    out = []
    for f107 in f107_levels:
        g2 = ml.solar_interpolation_of_dictionary(dict(f2), f107)
        g1 = ml.solar_interpolation_of_dictionary(dict(f1), f107)
        ge = ml.solar_interpolation_of_dictionary(dict(e), f107)
        g2["Nm"] = ml.limit_Nm(ml.freq2den(g2["fo"]))
        g1["Nm"] = ml.freq2den(g1["fo"])
        ge["Nm"] = ml.limit_Nm(ml.freq2den(ge["fo"]))
        out.append((g2, g1, ge))
    return out


_PROFILE_CHUNK = 2048
"""Points per call of PyIRI's profile builder, which fills some 20 (heights x points) arrays: at 2048 points and
61 heights (about 20 MB) they stay close to the processor's caches, and the profiles cost half of what they
cost at 8192 points. Each point's profile is its own (elementwise), so the chunk size does not change a bit."""


def density_profiles(params: tuple, alt_km) -> np.ndarray:
    """Electron density (electrons/m^3), shape (N, H), from one (F2, F1, E) triple of ``daily_parameters``
    at heights ``alt_km`` (1-D, km), by PyIRI's profile builder (Epstein layers, Forsythe et al. 2023)."""
    _, ml, _ = _pyiri()
    f2, f1, e = params
    alt = np.asarray(alt_km, float)
    n = f2["Nm"].shape[1]
    out = np.empty((n, alt.size))
    for a in range(0, n, _PROFILE_CHUNK):
        part = slice(a, a + _PROFILE_CHUNK)
        sub = tuple({k: v[:, part] for k, v in d.items()} for d in (f2, f1, e))
        out[part] = ml.reconstruct_density_from_parameters_1level(*sub, alt)[0].T
    return out


def electron_density(dates, ut_h, lon_deg, lat_deg, alt_km, f107: float, fof2_model: str = "ursi",
                     monthly: bool = False) -> np.ndarray:
    """Electron density (m^-3), shape (N, H), at N points (one date and UT each) and H heights (km)."""
    params = daily_parameters(dates, ut_h, lon_deg, lat_deg, [f107], fof2_model, monthly)[0]
    return density_profiles(params, alt_km)
