"""Speed of the calibration estimators, with ratios against straightforward reference implementations.

Targets (issue "Calibration estimators"): each estimator processes a 1000 x 1000-pixel simulated quad-pol
scene in under 2 s on one core; the Monte Carlo characterisation of an estimator (bias and SD over 1000
realisations) runs in under 10 s. Run: ``.venv/bin/python benchmarks/bench_calibration.py``.
Threads are pinned to one before numpy loads.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ[_var] = "1"

import time

import numpy as np

from e2esim.calibration.modules import CLUTTER_SHAPES
from e2esim.calibration.quegan1994 import block_covariances, quegan_calibrate, quegan_ratios
from e2esim.calibration.targets import Calibrators, calibrator_responses
from e2esim.calibration.transponder import solve_transponder
from e2esim.faraday.chirp import ChirpSlopeEstimator, sample_subband_covariances
from e2esim.faraday.estimators import BickelBates, FreemanSecondMoment, wrap_error
from e2esim.instrument.system_errors import SystemErrorModel
from e2esim.polarimetry.simulate import (
    SystemState,
    sample_measured_covariance,
    simulate_chirp_scene,
    simulate_scene,
)
from e2esim.scene.covariance import ScatteringCovariance
from e2esim.scene.table1 import TABLE1_FORESTS
from e2esim.units import db_to_linear, variance_from_level_db

SHAPE = (1000, 1000)
WINDOW = (10, 10)
F0, BW = 435e6, 6e6
NOISE = float(db_to_linear(-27.0))
REALISATIONS = 1000


def forest(name="boreal_200"):
    _, _, hh, hv, vv, r, t = TABLE1_FORESTS[name]
    return ScatteringCovariance.from_powers(hh, hv, vv, r, np.radians(t))


SYSTEM = SystemErrorModel(
    crosstalk_level=float(variance_from_level_db(-30, "three_sigma_amplitude")), crosstalk_rho13=0.9,
    crosstalk_rho24=0.9, imbalance_level=float(variance_from_level_db(-34, "three_sigma_amplitude")),
    imbalance_rho=0.9, noise_power=NOISE,
)


def timed(fn, repeat=3):
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


# -- straightforward references: a Python loop over windows / realisations ---------------------------
def ref_bickel_bates(img, window):
    wy, wx = window
    ny, nx = img.shape[0] // wy, img.shape[1] // wx
    out = np.empty((ny, nx))
    for i in range(ny):
        for j in range(nx):
            sl = (slice(i * wy, (i + 1) * wy), slice(j * wx, (j + 1) * wx))
            hh, hv, vh, vv = img.hh[sl], img.hv[sl], img.vh[sl], img.vv[sl]
            za = (hv - vh) + 1j * (hh + vv)
            zb = (vh - hv) + 1j * (hh + vv)
            out[i, j] = np.angle(np.mean(za * np.conj(zb))) / 4
    return out


def ref_quegan(img, window):
    wy, wx = window
    ny, nx = img.shape[0] // wy, img.shape[1] // wx
    out = np.empty((ny, nx), complex)
    for i in range(ny):
        for j in range(nx):
            sl = (slice(i * wy, (i + 1) * wy), slice(j * wx, (j + 1) * wx))
            m = np.stack([img.hh[sl].ravel(), img.hv[sl].ravel(), img.vh[sl].ravel(), img.vv[sl].ravel()])
            out[i, j] = quegan_ratios(m @ m.conj().T / m.shape[1])["u"]
    return out


def ref_chirp(img, window, est):
    """Per block, per frequency bin, a loop."""
    wy, wx = window
    ny, nx = img.shape[0] // wy, img.shape[1] // wx
    freq = BW * np.fft.fftfreq(wx)
    groups = np.array_split(np.argsort(freq), est.subbands)
    out = np.empty((ny, nx))
    for i in range(ny):
        for j in range(nx):
            sl = (slice(i * wy, (i + 1) * wy), slice(j * wx, (j + 1) * wx))
            za = np.fft.fft((img.hv[sl] - img.vh[sl]) + 1j * (img.hh[sl] + img.vv[sl]), axis=1)
            zb = np.fft.fft((img.vh[sl] - img.hv[sl]) + 1j * (img.hh[sl] + img.vv[sl]), axis=1)
            om = [np.angle(np.sum(za[:, g] * np.conj(zb[:, g]))) / 4 for g in groups]
            f = [F0 + freq[g].mean() for g in groups]
            out[i, j] = -0.5 * F0 * np.polyfit(np.array(f) - F0, np.unwrap(om, period=np.pi / 2), 1)[0]
    return out


def ref_mc_bickel_bates(rng, scene, looks, n):
    """Pixel-level Monte Carlo: simulate every window pixel by pixel, one realisation at a time."""
    errs = SYSTEM.sample(rng, n)
    out = np.empty(n)
    for k in range(n):
        state = SystemState(errs.delta[k], errs.f[k], 0.3, errs.gain[k])
        img = simulate_scene(rng, scene, (1, looks), state, NOISE)
        out[k] = wrap_error(BickelBates().estimate(img).omega - 0.3)
    return out


def report(name, t, target, t_ref=None):
    ok = "ok" if t < target else "SLOW"
    ratio = f"   reference {t_ref:7.3f} s   speed-up x{t_ref / t:7.1f}" if t_ref else ""
    print(f"  {name:52s} {t:7.3f} s  (target < {target:g} s: {ok}){ratio}")


def main():
    rng = np.random.default_rng(2018)
    scene = forest()
    s = SYSTEM.sample(rng, 1)
    state = SystemState(s.delta[0], s.f[0], np.radians(20.0), s.gain[0])
    img = simulate_scene(rng, scene, SHAPE, state, NOISE)
    chirp_img = simulate_chirp_scene(rng, scene, SHAPE, state, F0, BW, NOISE)
    print(f"Estimators on a {SHAPE[0]} x {SHAPE[1]}-pixel quad-pol scene, windows {WINDOW}, one core")
    t, bb = timed(lambda: BickelBates().estimate(img, WINDOW))
    t_ref, bb_ref = timed(lambda: ref_bickel_bates(img, WINDOW), repeat=1)
    assert np.allclose(bb.omega, bb_ref, atol=1e-9)
    report("Bickel-Bates (circular basis)", t, 2.0, t_ref)
    t, _ = timed(lambda: FreemanSecondMoment(NOISE).estimate(img, WINDOW))
    report("Freeman second moment", t, 2.0)
    est = ChirpSlopeEstimator(F0, BW, 4)
    cw = (100, 100)
    t, ch = timed(lambda: est.estimate(chirp_img, cw))
    t_ref, ch_ref = timed(lambda: ref_chirp(chirp_img, cw, est), repeat=1)
    assert np.allclose(ch.omega0, ch_ref, atol=1e-9)
    report(f"chirp slope, 4 sub-bands, windows {cw}", t, 2.0, t_ref)
    t, q = timed(lambda: quegan_calibrate(block_covariances(img, WINDOW)))
    t_ref, q_ref = timed(lambda: ref_quegan(img, WINDOW), repeat=1)
    assert np.allclose(q.u, q_ref, atol=1e-9)
    report("Quegan (1994) per window", t, 2.0, t_ref)
    cal = Calibrators.named(["transponder_hh", "transponder_hv", "transponder_vh", "transponder_vv"], 30.0,
                            CLUTTER_SHAPES["low_vegetation"], -50.0)
    pixels = [(100, 100), (300, 700), (600, 200), (900, 900)]

    def transponder_in_scene():
        m = img.vector()  # a scene of 10^6 pixels with four calibrators; responses read at their pixels
        responses = np.stack([m[p][[0, 2, 1, 3]].reshape(2, 2) for p in pixels])
        return solve_transponder(responses, cal)

    t, _ = timed(transponder_in_scene)
    report("transponder NLS on four calibrator pixels of the scene", t, 2.0)

    print(f"Monte Carlo characterisation (bias and SD over {REALISATIONS} realisations)")
    looks = 100
    tstate = lambda k: SystemState.from_samples(SYSTEM.sample(rng, k), np.full(k, 0.3))
    t, err = timed(lambda: wrap_error(BickelBates().from_covariance(
        sample_measured_covariance(rng, scene, tstate(REALISATIONS), NOISE, looks), looks).omega - 0.3))
    t_ref, err_ref = timed(lambda: ref_mc_bickel_bates(rng, scene, looks, REALISATIONS), repeat=1)
    report(f"Bickel-Bates, L = {looks} (Wishart windows)", t, 10.0, t_ref)
    print(f"      bias {np.degrees(err.mean()):+.3f} deg, SD {np.degrees(err.std()):.3f} deg; "
          f"pixel-level reference: bias {np.degrees(err_ref.mean()):+.3f}, SD {np.degrees(err_ref.std()):.3f} deg")
    t, _ = timed(lambda: FreemanSecondMoment(NOISE).from_covariance(
        sample_measured_covariance(rng, scene, tstate(REALISATIONS), NOISE, looks), looks))
    report("Freeman, L = 100", t, 10.0)
    t, _ = timed(lambda: est.from_subband_covariances(*sample_subband_covariances(
        rng, scene, tstate(REALISATIONS), NOISE, 400_000, est)))
    report("chirp slope, L = 4e5, 4 sub-bands", t, 10.0)
    t, _ = timed(lambda: quegan_calibrate(sample_measured_covariance(rng, scene, tstate(REALISATIONS), NOISE, 10**5),
                                          iterations=3))
    report("Quegan (1994), 3 passes, L = 1e5", t, 10.0)

    def transponder_mc():
        errs = SYSTEM.sample(rng, REALISATIONS)
        st = SystemState(errs.delta, errs.f, np.full(REALISATIONS, 0.8), errs.gain.astype(complex))
        return solve_transponder(calibrator_responses(rng, cal, st), cal)

    t, _ = timed(transponder_mc)
    report("transponder NLS, 4 calibrators at 30 dB SCR", t, 10.0)


if __name__ == "__main__":
    main()
