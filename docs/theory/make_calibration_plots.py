"""Make the figures of docs/theory/calibration.md (PNG files in docs/theory/img/) and print their numbers.

Run from the repository root: ``.venv/bin/python docs/theory/make_calibration_plots.py`` (about a minute).
Every figure is a simulation through e2esim's system model with a fixed seed.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from e2esim.calibration.modules import CLUTTER_SHAPES
from e2esim.calibration.pipeline import ResidualSampler, fit_residual_model
from e2esim.calibration.quegan1994 import quegan_calibrate
from e2esim.calibration.radiometric import ahmed_range_gain_error, swath_pointing_gain_sd_db
from e2esim.calibration.steps import FaradayStep, QueganStep, TransponderStep, TrihedralStep
from e2esim.calibration.targets import Calibrators, calibrator_responses
from e2esim.calibration.transponder import solve_transponder
from e2esim.distortion.analytic import hv_error_moments
from e2esim.faraday.chirp import (
    ChirpSlopeEstimator,
    chirp_omega0_sd,
    locate_zero_crossing,
    sample_subband_covariances,
)
from e2esim.faraday.distribution import ConstantFaraday, GaussianFaraday
from e2esim.faraday.estimator_modules import BickelBatesEstimator
from e2esim.faraday.estimators import BickelBates, wrap_error
from e2esim.faraday.theory import (
    bickel_bates_bias,
    bickel_bates_bias_first_order,
    bickel_bates_snr,
    bickel_bates_variance,
)
from e2esim.polarimetry.simulate import SystemState, measured_covariance, sample_measured_covariance
from e2esim.polarimetry.system_model import faraday_matrix
from e2esim.retrieval.agb_error import AGBError
from e2esim.retrieval.power_law import BIOME_EXPONENTS
from e2esim.verification.men2021 import forest, system

BB = BickelBatesEstimator()  # the default estimator of FaradayStep

OUT = Path(__file__).resolve().parent / "img"
F0, BW = 435e6, 6e6
NOISE = 10 ** (-27 / 10)
SPEC = system(-30.0, -34.0)
TRANSPONDERS = ["transponder_hh", "transponder_hv", "transponder_vh", "transponder_vv"]


def save(fig, name):
    OUT.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(OUT / name, dpi=110)
    plt.close(fig)
    print(f"wrote {OUT / name}")


def bb_variance(rng):
    scene = forest("boreal_200")
    looks = np.unique(np.round(np.logspace(0, 4, 17)).astype(int))
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for snr_db, colour in ((0.0, "C0"), (10.0, "C1"), (20.0, "C2")):
        sigma_n = bickel_bates_snr(scene, 1.0) / 10 ** (snr_db / 10)
        snr = bickel_bates_snr(scene, sigma_n)
        for form, style in (("exact", "-"), ("asymptotic", ":"), ("printed", "--")):
            sd = [np.degrees(np.sqrt(bickel_bates_variance(snr, int(L), form))) for L in looks]
            ax.loglog(
                looks,
                sd,
                style,
                color=colour,
                label=f"{snr_db:g} dB, {form}" if snr_db == 0 or form == "exact" else None,
            )
        mc = []
        for L in looks[::2]:
            cov = sample_measured_covariance(rng, scene, SystemState.ideal(np.zeros(4000)), sigma_n, int(L))
            mc.append(np.degrees(np.std(wrap_error(BickelBates().from_covariance(cov, int(L)).omega))))
        ax.loglog(looks[::2], mc, "o", color=colour, ms=4)
        print(f"  BB SD at {snr_db:g} dB, L=100: exact {np.degrees(np.sqrt(bickel_bates_variance(snr, 100))):.3f} deg, "
              f"printed eq.5 {np.degrees(np.sqrt(bickel_bates_variance(snr, 100, 'printed'))):.3f} deg")
    ax.set_xlabel("independent samples L")
    ax.set_ylabel("SD of the Bickel-Bates estimate (deg)")
    ax.set_title("Bickel-Bates: exact, Cramer-Rao (asymptotic), eq. (5) as printed; dots: simulation")
    ax.title.set_fontsize(9)
    ax.legend(fontsize=7, ncol=2)
    ax.grid(True, which="both", alpha=0.3)
    save(fig, "calibration_bb_variance.png")


def bb_crosstalk_bias(rng):
    scene = forest("boreal_200")
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    d = np.array([1.0, 0.5j, -0.8, 0.3 - 0.4j]) / np.sqrt(2.14)
    phi = np.linspace(0, 2 * np.pi, 181)
    for level_db in (-35.0, -30.0, -25.0):
        a = 10 ** (level_db / 20)
        for om, style in ((0.0, "-"), (np.pi / 3, "--")):
            b = bickel_bates_bias_first_order(scene, a * np.exp(1j * phi)[:, None] * d, np.ones(2), om)
            a1.plot(
                np.degrees(phi), np.degrees(b), style, label=f"|delta| {level_db:g} dB, Omega {np.degrees(om):.0f} deg"
            )
    a1.set_xlabel("common crosstalk phase (deg)")
    a1.set_ylabel("bias of Bickel-Bates (deg)")
    a1.legend(fontsize=7)
    a1.grid(alpha=0.3)
    levels = np.arange(-40, -14, 2.0)
    n = 4000
    for name, om in (("boreal_200", np.pi / 3), ("tropical_338", 0.0)):
        q = []
        for lev in levels:
            s = system(lev, -34.0).sample(rng, n)
            b = bickel_bates_bias(forest(name), SystemState(s.delta, s.f, np.full(n, om), np.ones(n)))
            q.append(np.degrees(np.quantile(np.abs(b), 0.99865)))
        a2.semilogy(levels, q, "o-", label=f"{name}, Omega {np.degrees(om):.0f} deg")
        print(f"  BB crosstalk bias 99.865% at -30 dB, {name}: {q[list(levels).index(-30.0)]:.2f} deg")
    a2.axhline(1.0, color="k", lw=0.8)
    a2.set_xlabel("crosstalk level (dB, 3-sigma label; rho = 0.9)")
    a2.set_ylabel("99.865 % of |bias| (deg)")
    a2.legend(fontsize=7)
    a2.grid(alpha=0.3, which="both")
    save(fig, "calibration_bb_crosstalk_bias.png")


def chirp(rng):
    scene = forest("boreal_200")
    est = ChirpSlopeEstimator(F0, BW, 4)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    looks = np.logspace(3, 8, 11)
    for snr_db in (10.0, 20.0, 30.0):
        sigma_n = bickel_bates_snr(scene, 1.0) / 10 ** (snr_db / 10)
        snr = bickel_bates_snr(scene, sigma_n)
        sd = [np.degrees(chirp_omega0_sd(snr, int(L), est)) for L in looks]
        a1.loglog(looks, sd, "-", label=f"slope, SNR {snr_db:g} dB")
        bb = [np.degrees(np.sqrt(bickel_bates_variance(snr, int(L)))) for L in looks]
        a1.loglog(looks, bb, ":", color=a1.lines[-1].get_color())
        need = (np.sqrt(3) / 4 * F0 / BW / np.radians(1.0)) ** 2 / snr  # asymptotic SD = 1 deg
        print(f"  chirp slope: SD < 1 deg needs L ~ {need:.1e} at SNR {snr_db:g} dB")
    sigma_n = NOISE
    for L in (1e5, 1e6, 1e7):
        covs, per = sample_subband_covariances(rng, scene, SystemState.ideal(np.full(2000, 0.1)), sigma_n, int(L), est)
        a1.loglog(L, np.degrees(np.std(est.from_subband_covariances(covs, per).omega0)), "ko", ms=4)
    a1.axhline(1.0, color="k", lw=0.8)
    a1.set_xlabel("independent samples L (all sub-bands)")
    a1.set_ylabel("SD of Omega0 (deg)")
    a1.set_title("eq. (12), 6 MHz at 435 MHz; dotted: full-band Bickel-Bates; dots: simulation", fontsize=8)
    a1.legend(fontsize=7)
    a1.grid(alpha=0.3, which="both")
    # frequency-dependent crosstalk
    change = np.linspace(0, 0.2, 9)
    s = SPEC.sample(np.random.default_rng(5), 300)
    for omega0_deg in (0.0, 5.0):
        rms = []
        for c in change:
            errs = []
            for dd, ff in zip(s.delta, s.f):
                om_k = np.radians(omega0_deg) * (F0 / est.frequencies) ** 2
                delta_k = dd[None, :] * (1 + c * (est.frequencies - F0)[:, None] / BW)
                cov = measured_covariance(
                    scene, SystemState(delta_k, np.broadcast_to(ff, (4, 2)), om_k, np.ones(4)), NOISE
                )
                errs.append(est.from_subband_covariances(cov, 10**9).omega0 - np.radians(omega0_deg))
            rms.append(np.degrees(np.sqrt(np.mean(np.square(errs)))))
        a2.plot(100 * change, rms, "o-", label=f"Omega0 = {omega0_deg:g} deg")
        print(f"  chirp slope, crosstalk changing {100 * change[4]:.0f} % across the band, Omega0 {omega0_deg:g}: "
              f"RMS error {rms[4]:.2f} deg")
    a2.set_xlabel("change of every crosstalk term across the band (%)")
    a2.set_ylabel("RMS error of Omega0 (deg), infinite window")
    a2.set_title("BIOMASS crosstalk statistics (-30 dB, rho 0.9)", fontsize=8)
    a2.legend(fontsize=7)
    a2.grid(alpha=0.3)
    save(fig, "calibration_chirp_slope.png")


def zero_fr_line(rng):
    """A track across the magnetic equator: Omega0 = g (lat - lat0), one window per 0.1 deg of latitude."""
    scene = forest("tropical_338")
    est = ChirpSlopeEstimator(F0, BW, 4)
    lat = np.arange(-3.0, 3.01, 0.1)
    lat0, gradient = 0.4, np.radians(0.8)  # Omega changes ~0.8 deg per deg of latitude near the equator
    omega = gradient * (lat - lat0)
    s = SPEC.sample(np.random.default_rng(9), 1)
    n = lat.size
    state = SystemState(np.repeat(s.delta, n, 0), np.repeat(s.f, n, 0), omega, np.ones(n))
    looks = 2_000_000
    bb = BickelBates().from_covariance(sample_measured_covariance(rng, scene, state, NOISE, looks), looks).omega
    covs, per = sample_subband_covariances(rng, scene, state, NOISE, looks, est)
    slope = est.from_subband_covariances(covs, per).omega0
    sd = chirp_omega0_sd(bickel_bates_snr(scene, NOISE), looks, est)
    x_bb, se_bb = locate_zero_crossing(lat, bb)
    x_sl, se_sl = locate_zero_crossing(lat, slope, sd)
    print(
        f"  zero-FR line (true {lat0} deg): Bickel-Bates {x_bb:.3f} +- {se_bb:.3f}, "
        f"chirp slope {x_sl:.3f} +- {se_sl:.3f}"
    )
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    ax.plot(lat, np.degrees(omega), "k-", label="true Omega")
    ax.plot(lat, np.degrees(bb), ".", label=f"Bickel-Bates: zero at {x_bb:.2f} +- {se_bb:.2f}")
    ax.plot(lat, np.degrees(slope), ".", label=f"chirp slope: zero at {x_sl:.2f} +- {se_sl:.2f}")
    ax.axvline(lat0, color="k", lw=0.6)
    ax.set_xlabel("latitude from the magnetic equator (deg)")
    ax.set_ylabel("Omega (deg)")
    ax.set_title(f"Zero-FR line, tropical forest, L = {looks:.0e} per window, one crosstalk realisation", fontsize=8)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    save(fig, "calibration_zero_fr_line.png")


def quegan(rng):
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    s = system(-30.0, -34.0).sample(np.random.default_rng(6), 200)
    scene = forest("boreal_200")
    omegas = np.array([0, 1, 2, 5, 10, 15, 20, 25, 30, 35, 40])
    one = np.ones(200)
    for it, style in ((1, "o-"), (5, "s--")):
        res = []
        for om in omegas:
            st = SystemState(s.delta, s.f, np.radians(om) * one, one)
            q = quegan_calibrate(measured_covariance(scene, st), it)
            rot = faraday_matrix(st.omega)
            r = np.stack([np.stack([one, s.delta[:, 1]], -1), np.stack([s.delta[:, 0], s.f[:, 0]], -1)], -2)
            xr = np.linalg.inv(q.receive) @ r @ rot
            res.append(
                10
                * np.log10(np.mean(np.abs(xr[:, 1, 0] / xr[:, 0, 0]) ** 2 + np.abs(xr[:, 0, 1] / xr[:, 0, 0]) ** 2) / 2)
            )
        a1.plot(omegas, res, style, label=f"{it} pass{'es' if it > 1 else ''}")
    a1.axhline(10 * np.log10(SPEC.crosstalk_level), color="k", lw=0.8, label="raw crosstalk")
    a1.set_xlabel("Faraday rotation (deg), not corrected")
    a1.set_ylabel("residual crosstalk power (dB)")
    a1.set_title("Quegan (1994) on boreal 200 t/ha, infinite window", fontsize=8)
    a1.legend(fontsize=7)
    a1.grid(alpha=0.3)
    ratios = np.linspace(0.02, 0.6, 15)
    from e2esim.scene.covariance import ScatteringCovariance
    for name, style in (("boreal_200", "-"), ("tropical_338", "--")):
        base = forest(name)
        for it, colour in ((1, "C0"), (3, "C1"), (10, "C2")):
            err = []
            for r in ratios:
                c = base.matrix.copy()
                c[1, 1] = r * c[0, 0]
                st = SystemState(s.delta, s.f, 0 * one, one)
                q = quegan_calibrate(measured_covariance(ScatteringCovariance(c), st), it)
                err.append(10 * np.log10(np.mean(np.abs(q.delta - s.delta) ** 2)))
            a2.plot(ratios, err, style, color=colour, label=f"{name} covariance, {it} pass{'es' if it > 1 else ''}")
        a2.axvline(base.sigma_hv / base.sigma_hh, color="grey", lw=0.6, ls=style)
    a2.axhline(10 * np.log10(SPEC.crosstalk_level), color="k", lw=0.8, label="raw crosstalk")
    a2.set_ylim(-90, 5)
    a2.set_xlabel("sigma_hv / sigma_hh (sigma_hv scaled; grey: the Table I value)")
    a2.set_ylabel("crosstalk estimation error power (dB)")
    a2.set_title("bias from the neglected HV terms, Omega = 0", fontsize=8)
    a2.legend(fontsize=6)
    a2.grid(alpha=0.3)
    save(fig, "calibration_quegan_limits.png")


def transponder(rng):
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    scr = np.arange(20.0, 56.0, 5.0)
    n = 1500
    for om in (0.0, 60.0):
        sd_mc, sd_crb = [], []
        for v in scr:
            cal = Calibrators.named(TRANSPONDERS, v, CLUTTER_SHAPES["low_vegetation"], -60.0)
            e = SPEC.sample(rng, n)
            st = SystemState(e.delta, e.f, np.full(n, np.radians(om)), e.gain.astype(complex))
            sol = solve_transponder(
                calibrator_responses(rng, cal, st), cal, "faraday_prior", faraday_prior=(st.omega, 0.0)
            )
            sd_mc.append(np.sqrt(np.mean(np.abs(sol.delta - e.delta) ** 2)))
            sd_crb.append(np.sqrt(np.mean(np.real(np.diagonal(sol.covariance, axis1=-2, axis2=-1))[:, :4])))
        a1.semilogy(scr, sd_mc, "o", label=f"simulation, Omega {om:g} deg")
        a1.semilogy(scr, sd_crb, "-", color=a1.lines[-1].get_color(), label=f"Cramer-Rao, Omega {om:g} deg")
    a1.axhline(np.sqrt(SPEC.crosstalk_level), color="k", lw=0.8, label="RMS crosstalk at -30 dB spec")
    a1.set_xlabel("signal-to-clutter ratio (dB)")
    a1.set_ylabel("RMS error of delta_i")
    a1.set_title("four transponders, Omega known", fontsize=8)
    a1.legend(fontsize=7)
    a1.grid(alpha=0.3, which="both")
    scene, fr = forest("tropical_338"), GaussianFaraday(0.0, np.radians(5.0))
    raw = float(hv_error_moments(scene, SPEC, fr, looks=100_000).sd) / scene.sigma_hv
    for ag, style in ((True, "o-"), (False, "s--")):
        out = []
        for v in scr:
            cal = Calibrators.named(TRANSPONDERS, v, CLUTTER_SHAPES["low_vegetation"], -60.0)
            smp = ResidualSampler(SPEC, fr, scene, NOISE, (TransponderStep(cal, absolute_gain=ag), FaradayStep(BB)))
            model, _ = fit_residual_model(smp.sample(rng, 2000), NOISE)
            out.append(float(hv_error_moments(scene, model, ConstantFaraday(0.0), looks=100_000).sd) / scene.sigma_hv)
        a2.semilogy(scr, out, style, label=f"transponders, absolute_gain {ag}")
    tri_out = []
    for v in scr:
        cal = Calibrators.named(["trihedral"] * 4, v, CLUTTER_SHAPES["low_vegetation"], -60.0)
        smp = ResidualSampler(SPEC, fr, scene, NOISE, (FaradayStep(BB), QueganStep(), TrihedralStep(cal, False)))
        model, _ = fit_residual_model(smp.sample(rng, 2000), NOISE)
        tri_out.append(float(hv_error_moments(scene, model, ConstantFaraday(0.0), looks=100_000).sd) / scene.sigma_hv)
    a2.semilogy(scr, tri_out, "^-", label="FR + Quegan + 4 trihedrals")
    a2.axhline(raw, color="k", lw=0.8, label="no calibration")
    a2.set_xlabel("signal-to-clutter ratio (dB)")
    a2.set_ylabel("SD of sigma_hv error / sigma_hv")
    a2.set_title("tropical 338 t/ha, BIOMASS specification", fontsize=8)
    a2.legend(fontsize=7)
    a2.grid(alpha=0.3, which="both")
    print(f"  sigma_hv relative SD: raw {raw:.4f}; transponders absolute at 30 dB: "
          f"{a2.lines[0].get_ydata()[2]:.4f}; relative at 30 dB {a2.lines[1].get_ydata()[2]:.4f}")
    save(fig, "calibration_transponder_scr.png")


def strategies(rng):
    cal30 = Calibrators.named(TRANSPONDERS, 30.0, CLUTTER_SHAPES["low_vegetation"], -60.0)
    tri = Calibrators.named(["trihedral"] * 4, 40.0, CLUTTER_SHAPES["low_vegetation"], -60.0)
    plans = {
        "none": None,
        "FR corrected": None,
        "FR + Quegan": (FaradayStep(BB), QueganStep()),
        "FR + Quegan + 4 trihedrals (40 dB), relative": (FaradayStep(BB), QueganStep(), TrihedralStep(tri, False)),
        "FR + Quegan + 4 trihedrals (40 dB), absolute": (FaradayStep(BB), QueganStep(), TrihedralStep(tri, True)),
        "transponders (30 dB) + FR": (TransponderStep(cal30), FaradayStep(BB)),
    }
    fig, ax = plt.subplots(figsize=(9, 4.4))
    width = 0.38
    for k, (name, fr) in enumerate((("boreal_200", GaussianFaraday(np.pi / 3, np.radians(5))),
                                    ("tropical_338", GaussianFaraday(0.0, np.radians(5))))):
        scene = forest(name)
        q = []
        for steps in plans.values():
            if steps is None:
                m = hv_error_moments(scene, SPEC, fr, looks=100_000)
            else:
                model, _ = fit_residual_model(ResidualSampler(SPEC, fr, scene, NOISE, steps).sample(rng, 4000), NOISE)
                m = hv_error_moments(scene, model, ConstantFaraday(0.0), looks=100_000)
            agb = AGBError(BIOME_EXPONENTS[scene.biome], scene.sigma_hv, float(m.mean), float(m.sd))
            q.append(100 * float(agb.quantile(0.99865)))
        ax.bar(np.arange(len(plans)) + (k - 0.5) * width, q, width, label=name)
        print(f"  {name}: 99.865 % AGB error by strategy " + ", ".join(f"{lab}: {v:.1f} %" for lab, v in zip(plans, q)))
    ax.set_xticks(np.arange(len(plans)))
    ax.set_xticklabels([p.replace(", ", ",\n").replace(" + ", "\n+ ") for p in plans], fontsize=6)
    ax.set_ylabel("99.865 % quantile of the AGB error (%)")
    ax.set_title("BIOMASS specification, NESZ -27 dB (analytic model of the residuals)", fontsize=8)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3, axis="y")
    save(fig, "calibration_strategies.png")


def radiometric():
    bw = np.radians(5.0)
    sds = np.linspace(0.0, 0.5, 11)
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for frac in (1.0, 0.5):
        ax.plot(sds, [swath_pointing_gain_sd_db(np.radians(s), bw, swath_fraction=frac) for s in sds], "o-",
                label=f"exact sinc^2 pattern, swath = {frac:g} x half-power beam")
    lin = [abs(4.343 * 2 * float(ahmed_range_gain_error(np.radians(s), bw))) for s in sds]
    ax.plot(sds, lin, "k--", label="Ahmed et al. (2014) eq. (33), transmit + receive (eq. 32, range terms)")
    ax.set_xlabel("elevation pointing error SD (deg), beamwidth 5 deg")
    ax.set_ylabel("RMS gain error (dB)")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    save(fig, "calibration_radiometric.png")


def main():
    rng = np.random.default_rng(2018)
    for fn in (bb_variance, bb_crosstalk_bias, chirp, zero_fr_line, quegan, transponder, strategies):
        fn(rng)
    radiometric()


if __name__ == "__main__":
    main()
