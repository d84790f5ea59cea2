"""The International Geomagnetic Reference Field (IGRF) through ppigrf's coefficient files.

``igrf_reference`` calls ``ppigrf.igrf_gc`` itself (the reference implementation, about 40 us per
point). ``igrf_geocentric`` evaluates the same spherical-harmonic expansion with the same Schmidt
semi-normalised Legendre recursion (Wertz 1978, as in ppigrf), but without forming the dense design
matrices and in cache-sized chunks, about 8 times faster; tests/test_geomag.py checks it against
``ppigrf.igrf_gc`` to 1e-9 and benchmarks/bench_climatology.py prints the ratio. Coefficients are
interpolated linearly in time between the IGRF epochs of the file, like ppigrf (Alken et al. 2021,
IGRF-13; IGRF-14, 2024).

Coordinates: geocentric radius r (m), colatitude theta (rad), east longitude phi (rad); field components
(T) radial (up), theta (south) and phi (east).
"""

from __future__ import annotations

import datetime as dt
import functools

import numpy as np

from e2esim.errors import PhysicsInputError

IGRF_REFERENCE_RADIUS = 6371.2e3
"""a of the IGRF expansion (m)."""

_NT = 1e-9  # T per nT


@functools.lru_cache(maxsize=4)
def _coefficient_table(model: str):
    import ppigrf.ppigrf as pp

    path = {"IGRF14": pp.shc_fn_igrf14, "IGRF13": pp.shc_fn_igrf13}[model]
    g, h = pp.read_shc(path)
    seconds = np.array([_seconds(t.to_pydatetime()) for t in g.index])
    keys = list(g.columns)
    return seconds, keys, g.values.astype(float), h.values.astype(float)


IGRF_MODELS = ("IGRF14", "IGRF13")


def _seconds(when: dt.datetime) -> float:
    """Seconds since 1900-01-01: coefficients are linear in time between epochs, as in ppigrf."""
    return (when - dt.datetime(1900, 1, 1)).total_seconds()


def to_datetime(when) -> dt.datetime:
    """A datetime from a datetime, date, numpy datetime64 or ISO string."""
    if isinstance(when, dt.datetime):
        return when.replace(tzinfo=None)
    if isinstance(when, dt.date):
        return dt.datetime(when.year, when.month, when.day)
    if isinstance(when, np.datetime64):
        return dt.datetime.fromisoformat(str(when.astype("datetime64[s]")))
    if isinstance(when, str):
        try:
            return dt.datetime.fromisoformat(when)
        except ValueError as exc:
            raise PhysicsInputError(f"{when!r} is not an ISO date (YYYY-MM-DD[THH:MM:SS])") from exc
    raise PhysicsInputError(f"{when!r} is not a date")


def gauss_coefficients(when, model: str = "IGRF14") -> dict:
    """Gauss coefficients (T) at a date: ``{(n, m): (g, h)}``, linear in time between epochs.

    Raises PhysicsInputError outside the epochs the file covers (IGRF-14: 1900-2030).
    """
    epochs, keys, g, h = _coefficient_table(model)
    t = _seconds(to_datetime(when))
    if not epochs[0] <= t <= epochs[-1]:
        first = dt.datetime(1900, 1, 1) + dt.timedelta(seconds=float(epochs[0]))
        last = dt.datetime(1900, 1, 1) + dt.timedelta(seconds=float(epochs[-1]))
        raise PhysicsInputError(f"date {to_datetime(when).date()} is outside {model} ({first.year} to {last.year})")
    gi = np.array([np.interp(t, epochs, g[:, j]) for j in range(len(keys))]) * _NT
    hi = np.array([np.interp(t, epochs, h[:, j]) for j in range(len(keys))]) * _NT
    return {key: (gi[j], hi[j]) for j, key in enumerate(keys)}


def dipole_coefficients(when, model: str = "IGRF14") -> tuple[float, float, float]:
    """(g_1^0, g_1^1, h_1^1) in T at a date: the centred-dipole part of IGRF."""
    c = gauss_coefficients(when, model)
    return float(c[(1, 0)][0]), float(c[(1, 1)][0]), float(c[(1, 1)][1])


def _schmidt_legendre(nmax: int, cos_t, sin_t):
    """Schmidt semi-normalised P_n^m(cos theta) and dP/dtheta, dicts keyed by (n, m) (Wertz 1978)."""
    P = {(0, 0): np.ones_like(cos_t)}
    dP = {(0, 0): np.zeros_like(cos_t)}
    for n in range(1, nmax + 1):
        for m in range(0, n + 1):
            if n == m:
                P[n, n] = sin_t * P[n - 1, n - 1]
                dP[n, n] = sin_t * dP[n - 1, n - 1] + cos_t * P[n - 1, n - 1]
            elif n == 1:
                P[n, m] = cos_t * P[n - 1, m]
                dP[n, m] = cos_t * dP[n - 1, m] - sin_t * P[n - 1, m]
            else:
                k = ((n - 1) ** 2 - m**2) / ((2 * n - 1) * (2 * n - 3))
                pm2 = P.get((n - 2, m), 0.0)
                dpm2 = dP.get((n - 2, m), 0.0)
                P[n, m] = cos_t * P[n - 1, m] - k * pm2
                dP[n, m] = cos_t * dP[n - 1, m] - sin_t * P[n - 1, m] - k * dpm2
    # Schmidt normalisation factors (Gauss-normalised recursion above -> Schmidt semi-normalised)
    S = {(0, 0): 1.0}
    for n in range(1, nmax + 1):
        S[n, 0] = S[n - 1, 0] * (2.0 * n - 1) / n
        for m in range(1, n + 1):
            S[n, m] = S[n, m - 1] * np.sqrt((n - m + 1) * ((m == 1) + 1.0) / (n + m))
    for key in P:
        P[key] = P[key] * S[key]
        dP[key] = dP[key] * S[key]
    return P, dP


def igrf_geocentric(r, theta, phi, when, model: str = "IGRF14", min_degree: int = 1, max_degree: int = 13):
    """IGRF field (T) at geocentric positions: ``(B_r, B_theta, B_phi)`` (up, south, east).

    r : geocentric radius (m); theta : colatitude (rad); phi : east longitude (rad); any broadcastable
    shapes. when : the date. ``max_degree = 1`` gives the centred (tilted) dipole of the model.
    """
    r, theta, phi = np.broadcast_arrays(np.asarray(r, float), np.asarray(theta, float), np.asarray(phi, float))
    coeffs = gauss_coefficients(when, model)
    shape = r.shape
    r, theta, phi = r.ravel(), theta.ravel(), phi.ravel()
    out = np.empty((3, r.size))
    for start in range(0, r.size, _CHUNK):  # chunks that stay in cache: faster than one pass
        part = slice(start, start + _CHUNK)
        out[:, part] = _synthesis(r[part], theta[part], phi[part], coeffs, min_degree, max_degree)
    return out[0].reshape(shape), out[1].reshape(shape), out[2].reshape(shape)


_CHUNK = 16384


def _synthesis(r, theta, phi, coeffs, min_degree, max_degree):
    cos_t, sin_t = np.cos(theta), np.sin(theta)
    P, dP = _schmidt_legendre(max_degree, cos_t, sin_t)
    ratio = IGRF_REFERENCE_RADIUS / r
    cos_m = [np.ones_like(phi)] + [np.cos(m * phi) for m in range(1, max_degree + 1)]
    sin_m = [np.zeros_like(phi)] + [np.sin(m * phi) for m in range(1, max_degree + 1)]
    br = np.zeros_like(r)
    bt = np.zeros_like(r)
    bp = np.zeros_like(r)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv_sin = np.where(sin_t > 1e-12, 1.0 / np.where(sin_t > 1e-12, sin_t, 1.0), 0.0)
    for n in range(min_degree, max_degree + 1):
        rn = ratio ** (n + 2)
        for m in range(0, n + 1):
            g, h = coeffs[(n, m)]
            gc_hs = g * cos_m[m] + h * sin_m[m]
            br += rn * (n + 1) * P[n, m] * gc_hs
            bt -= rn * dP[n, m] * gc_hs
            if m:
                bp += rn * m * P[n, m] * (g * sin_m[m] - h * cos_m[m]) * inv_sin
    return br, bt, bp


def igrf_reference(r, theta, phi, when, model: str = "IGRF14", min_degree: int = 1, max_degree: int = 13):
    """Same as ``igrf_geocentric`` through ``ppigrf.igrf_gc`` itself (the slow reference)."""
    import ppigrf
    import ppigrf.ppigrf as pp

    path = {"IGRF14": pp.shc_fn_igrf14, "IGRF13": pp.shc_fn_igrf13}[model]
    br, bt, bp = ppigrf.igrf_gc(np.asarray(r) / 1e3, np.degrees(theta), np.degrees(phi), to_datetime(when),
                                coeff_fn=path, min_degree=min_degree, max_degree=max_degree)
    return br[0] * _NT, bt[0] * _NT, bp[0] * _NT
