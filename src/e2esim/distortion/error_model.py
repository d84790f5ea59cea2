"""The error model of sigma_hv under crosstalk, channel imbalance, Faraday rotation, noise and gain.

``HVErrorModel`` is what the ``hv_backscatter_error`` stage provides as ``backscatter.error``: the analytic
moments of Men et al. (2021), eqs. (11)-(12) (``e2esim.distortion.analytic``, completed to second order),
evaluated at any error level, with any source removed, and split into contributions; plus the Monte Carlo
errors of the full system model when simulated (``e2esim.distortion.montecarlo``). Every evaluation is made
once per model object and kept with it, so the retrieval and every requirement of a case share them.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from e2esim.block import Batched, Values, join
from e2esim.case_values import plain
from e2esim.derived import EvaluatedOnce, RemovedOnce, knowing
from e2esim.distortion.analytic import HVErrorMoments, MomentInputs, check_settings, moments_of
from e2esim.distortion.validation import compare_with_analytic, sample_moments
from e2esim.distortion.validity import VALIDITY, ValidityRange
from e2esim.error_model import Contribution, ErrorModel, ErrorModelUnavailable, ModelEvaluation
from e2esim.faraday.distribution import ConstantFaraday, FaradayDistribution
from e2esim.instrument.system_errors import SystemErrorModel
from e2esim.scene.covariance import ScatteringCovariance

LEVELS = ("crosstalk", "channel_imbalance", "nesz")
"""Levels ``moments`` accepts: V_delta and V_eps (variances of the error terms) and sigma_n (noise power,
m^2/m^2, the NESZ as a linear ratio)."""

SOURCES = ("crosstalk", "channel_imbalance", "noise", "faraday_rotation", "gain")
"""Sources ``without`` removes: a level set to zero, no Faraday rotation, or no absolute gain error."""

CONTRIBUTION_DESCRIPTIONS = {
    "system_distortions": "crosstalk, channel imbalance and gain errors without Faraday rotation (Men et al. 2021)",
    "faraday_rotation": "what the case's Faraday rotation adds to the system-distortion error",
    "noise_bias": "thermal-noise bias sigma_n/2 of the HV estimate and its spread over the simulated looks",
}
_LEVEL_SOURCES = {"crosstalk": 0, "channel_imbalance": 1, "noise": 2}  # rows of the batched variants
_NO_ROTATION = ConstantFaraday(0.0)


class SystemLevels(RemovedOnce):
    """What the distortion error models share: the levels are the system's (V_delta, V_eps, sigma_n), the
    sources ``SOURCES``, speckle counts for the population reference, and ``without`` is made once for every
    source (``RemovedOnce``; ``_without`` makes the variant). Needs ``system`` and ``reference`` fields."""

    @property
    def includes_speckle(self) -> bool:
        return self.reference == "population"

    @property
    def levels(self) -> dict:
        s = self.system
        return {"crosstalk": s.crosstalk_level, "channel_imbalance": s.imbalance_level, "nesz": s.noise_power}

    @property
    def sources(self) -> tuple:
        return SOURCES


@dataclass(frozen=True, eq=False)
class HVErrorModel(Batched, SystemLevels, EvaluatedOnce, ModelEvaluation, ErrorModel):
    """Error of sigma_hv_hat for one case, or for a block of cases with a leading case axis.

    scene, system, faraday : what the error is computed for (the residual system and Faraday rotation
        after calibration): one case's products, or a block's (``e2esim.block``), for ``item``. form : setting
        of the analytic moments (``hv_error_moments``), with the keyword-only ``looks`` and ``reference``
        (``ModelEvaluation``; its ``montecarlo`` is a ``MonteCarloErrors``). inputs : the ``MomentInputs`` of
        the moments, case shape () or (B,) (None: those of scene, system and faraday, one case). inactive : for
        a model with a source removed (``without``), where that source was not active (a model where no case
        has it, a case alone among them, is its own variant).
    """

    scene: ScatteringCovariance
    system: SystemErrorModel
    faraday: FaradayDistribution
    form: str = "complete"
    inputs: MomentInputs | None = None
    inactive: object = None

    channel = "hv"

    @property
    def validity(self) -> ValidityRange:
        """The measured validity range of the analytic form (docs/theory/validity.md)."""
        return VALIDITY["hv_" + self.form]

    @property
    def moment_inputs(self) -> MomentInputs:
        return self.own_inputs if self.inputs is None else self.inputs

    @cached_property
    def own_inputs(self) -> MomentInputs:
        """The ``MomentInputs`` of scene, system and faraday (one case), derived once."""
        return MomentInputs.of(self.scene, self.system, self.faraday, self.form)

    @property
    def value(self):
        return self.scene.sigma_hv if self.inputs is None else self.inputs.terms.sigma_hv

    @property
    def levels(self) -> dict:
        if self.inputs is None:
            return SystemLevels.levels.fget(self)
        xs, es, ns = self.inputs.levels
        return {"crosstalk": xs, "channel_imbalance": es, "nesz": ns}

    # Moments ---------------------------------------------------------------------------------------
    def moments(self, crosstalk=None, channel_imbalance=None, nesz=None, **unknown) -> HVErrorMoments:
        """``hv_error_moments`` with the levels V_delta, V_eps and sigma_n replaced where given (broadcast; with a
        case axis, aligned on it)."""
        if unknown:
            raise TypeError(f"unknown levels {', '.join(unknown)}; this model has {', '.join(LEVELS)}")
        self.check_available()
        check_settings(self.form, self.reference)
        if crosstalk is None and channel_imbalance is None and nesz is None:
            return self.own_moments
        return moments_of(self.moment_inputs, self.form, self.looks, self.reference, crosstalk_level=crosstalk,
                          imbalance_level=channel_imbalance, noise_power=nesz)

    @cached_property
    def own_moments(self) -> HVErrorMoments:
        """``moments()`` at its own levels, derived once (the error terms' variants of a Shapley split, its bound
        and its attribution ask the same model)."""
        return moments_of(self.moment_inputs, self.form, self.looks, self.reference, crosstalk_level=None,
                          imbalance_level=None, noise_power=None)

    # Sources removed (``SystemLevels.without``) ----------------------------------------------------
    def _without(self, source: str) -> HVErrorModel:
        """The model with ``source`` removed: the model itself where no case has it (a case alone is a block of
        one), else a variant that marks the cases without it (``inactive``)."""
        inp = self.moment_inputs
        shape = np.shape(inp.levels[0])
        if source == "faraday_rotation":
            return self if np.all(inp.no_rotation) else self._no_faraday()
        if source == "gain":
            if np.all(inp.no_gain_error):
                return self
            return self._variant(dataclasses.replace(inp, gain=(np.ones(shape), np.ones(shape))), inp.no_gain_error)
        # the three level sources in one vectorised evaluation: [no crosstalk, no imbalance, no noise]
        xs, es, ns = inp.levels
        row = _LEVEL_SOURCES[source]
        levels = [xs, es, ns]
        levels[row] = np.zeros(shape)[()]  # a float for a case alone (shape ()), an array over a block's cases
        variant = self._variant(dataclasses.replace(inp, levels=tuple(levels)), np.zeros(shape, dtype=bool))
        return knowing(variant, evaluated=_row(self.level_variants, row, len(shape)))

    @cached_property
    def level_variants(self) -> HVErrorMoments:
        """The moments without each level source, [no crosstalk, no imbalance, no noise] on a last axis: the three
        in one vectorised evaluation, once."""
        xs, es, ns = self.moment_inputs.levels
        z = np.zeros(np.shape(xs))
        return self.moments(crosstalk=np.stack([z, xs, xs], -1), channel_imbalance=np.stack([es, z, es], -1),
                            nesz=np.stack([ns, ns, z], -1))

    def _no_faraday(self) -> HVErrorModel:
        """The model without Faraday rotation (also where there is none: the contributions' reference)."""
        return self.no_faraday

    @cached_property
    def no_faraday(self) -> HVErrorModel:
        """``_no_faraday()``, made once."""
        inp = self.moment_inputs
        shape = np.shape(inp.levels[0])
        if self.form == "paper":
            averaging = {k: np.full(shape, v) for k, v in _NO_ROTATION.trig_moments().items()}
        else:
            weights = _NO_ROTATION.even_quadrature()[1]
            averaging = np.broadcast_to(weights, shape + weights.shape)
        return self._variant(dataclasses.replace(inp, averaging=averaging), inp.no_rotation)

    def _variant(self, inputs: MomentInputs, inactive) -> HVErrorModel:
        """The model with ``inputs``, the same for a case alone and a block: its moments are those of ``inputs``
        (the products it keeps are the model's, read only by ``item``); no Monte Carlo samples, which belong to
        the full model. ``inactive`` (case shape) marks the cases without the source; None where every case has
        it."""
        return dataclasses.replace(self, montecarlo=None, gaussianity=None, notes=(), inputs=inputs,
                                   inactive=inactive if np.any(inactive) else None)

    # Contributions ---------------------------------------------------------------------------------
    def contributions(self) -> dict:
        """The error split into system distortions (the same system with no Faraday rotation), what the
        Faraday rotation adds to it (FR alone leaves the symmetrised HV unchanged, so it acts only through the
        distortions) and the noise bias sigma_n/2 with its spread over the looks; they add up to the mean
        and variance exactly. Arrays over the case axis of a block."""
        return split_contributions(self.current(), self._no_faraday().current())

    # Monte Carlo -----------------------------------------------------------------------------------
    def relative_samples(self) -> np.ndarray | None:
        if self.montecarlo is None:
            return None
        ref = np.asarray(self.montecarlo.reference["hv"])
        return self.montecarlo.hv / (ref[:, None] if ref.ndim else ref)

    def samples(self) -> np.ndarray | None:
        return None if self.montecarlo is None else self.montecarlo.hv

    # Output ----------------------------------------------------------------------------------------
    def scalars(self) -> dict:
        """``analytic.*`` (every part of the moments, m^2/m^2), ``montecarlo.*`` (sample moments with standard
        errors, Gaussianity) and ``comparison.*`` (eq. 18 differences with standard errors)."""
        out: dict = {}
        analytic = None
        if self.unavailable is None:
            analytic = self.current()
            out.update({name: float(value) for name, value in analytic_scalars(analytic).items()})
        mc = self.montecarlo
        if mc is not None:
            for name, value in sample_moments(mc.hv).items():
                out[f"montecarlo.{name}"] = value
            out["montecarlo.sd"] = math.sqrt(max(out["montecarlo.variance"], 0.0))
            for name, value in (self.gaussianity or {}).items():
                out[f"montecarlo.{name}"] = value
        if analytic is not None and mc is not None:
            cmp = compare_with_analytic(float(analytic.mean), float(analytic.variance), mc.hv, mc.looks,
                                        fixed_scene=self.reference == "scene")
            out.update({f"comparison.{name}": value for name, value in cmp.items()})
        return out

    # A block of cases (``e2esim.block.Batched``): analytic cases only ---------------------------------------
    @property
    def case_shape(self) -> tuple:
        """() for one case (its products have no case axis), (B,) for a block."""
        return np.shape(self.value)

    def block_item(self, i: int) -> HVErrorModel:
        """Case i's one-case model, with the moments the block computed for it."""
        model = HVErrorModel(self.scene.item(i), self.system.item(i), self.faraday.item(i), self.form,
                             looks=self.looks, reference=self.reference)
        if "evaluated" in vars(self):
            knowing(model, evaluated=_row(self.evaluated, i, 0))
        return model

    def take(self, positions) -> HVErrorModel:
        return dataclasses.replace(self, scene=self.scene.take(positions), system=self.system.take(positions),
                                   faraday=self.faraday.take(positions), inputs=self.inputs.take(positions),
                                   inactive=None if self.inactive is None else self.inactive[positions])

    @classmethod
    def concatenate(cls, parts: list) -> HVErrorModel:
        first = parts[0]
        if any((p.form, p.looks, p.reference) != (first.form, first.looks, first.reference) for p in parts):
            raise ValueError("blocks of error models with different settings cannot be joined")
        return dataclasses.replace(first, scene=join([p.scene for p in parts]), system=join([p.system for p in parts]),
                                   faraday=join([p.faraday for p in parts]),
                                   inputs=MomentInputs.concatenate([p.inputs for p in parts]),
                                   inactive=_joined_inactive(parts))

    def scalar_columns(self) -> dict:
        return dict(analytic_scalars(self.current()))

    def note_column(self) -> Values:
        return Values.repeated(self.notes, len(self))


def _joined_inactive(parts: list):
    """The ``inactive`` marks of joined blocks: None where every case of every part has the source."""
    if all(p.inactive is None for p in parts):
        return None
    return np.concatenate([np.zeros(len(p), dtype=bool) if p.inactive is None else p.inactive for p in parts])


def split_contributions(m, m0, convert=None) -> dict:
    """``HVErrorModel.contributions`` from the moments ``m`` of the model and ``m0`` of the same model without
    Faraday rotation (scalars or arrays over cases), ``convert`` applied to each part (None: a float for a case
    alone, the array over a block's cases)."""
    convert = plain if convert is None else convert
    sd_mean = convert(m0.mean - m0.bias_noise)
    sd_var = convert(m0.variance - m0.var_finite_looks)
    values = {
        "system_distortions": (sd_mean, sd_var),
        "faraday_rotation": (
            convert(m.mean - m.bias_noise) - sd_mean,
            convert(m.variance - m.var_finite_looks) - sd_var,
        ),
        "noise_bias": (convert(m.bias_noise), convert(m.var_finite_looks)),
    }
    return {name: Contribution(mean, var, CONTRIBUTION_DESCRIPTIONS[name]) for name, (mean, var) in values.items()}


def analytic_scalars(m) -> dict:
    """``analytic.*`` output scalars of moments ``m`` (every part, m^2/m^2, and the SD)."""
    out = {f"analytic.{name}": value for name, value in m.as_dict().items() if name not in ("form", "sigma_hv")}
    out["analytic.sd"] = m.sd
    return out


def _row(moments: HVErrorMoments, i: int, case_ndim: int) -> HVErrorMoments:
    """Element ``i`` of the last axis of moments evaluated over a vector of levels (or over the cases of a block,
    ``case_ndim`` 0), arrays with more than ``case_ndim`` axes."""
    values = {f.name: getattr(moments, f.name) for f in dataclasses.fields(moments)}
    return HVErrorMoments(**{k: (v[..., i] if isinstance(v, np.ndarray) and v.ndim > case_ndim else v)
                             for k, v in values.items()})


__all__ = ["LEVELS", "SOURCES", "ErrorModelUnavailable", "HVErrorModel"]
