"""The polarimetric distortion of a BIOMASS L1 product's annotation as the instrument's (issue 26, item 5): module
types ``biomass_product_distortion`` (the BIOMASS preset with the annotation's crosstalk and channel imbalance) and
``biomass_product_instrument`` (the same, with the noise of the LUT as ``biomass_product_noise``). docs/real-data.md,
"A scenario driven by a product".

Convention (BioPAL BPS v4.3.0, ``xsd/biomass-xsd/bio-common-types.xsd``, types ``crossTalkList`` and
``channelImbalanceList``; the annotation holds the AUX_PP1 calibration constants the processor used, written by
``bps-l1_processor/.../post/interface.py`` from ``aux_pp1.polarimetric_calibration``): every term is a ``complex``
(``re``, ``im``), a linear amplitude ratio (no dB, not a power; ``bps-l1_core_processor/.../translate.py`` hands it
to the focuser as amplitude ``abs`` and phase ``atan2``). In the system model of docs/conventions.md, ``M = R F S F
T`` with ``R = [[1, delta2], [delta1, f1]]`` and ``T = [[1, delta3], [delta4, f2]]`` (Quegan et al. 2018, eq. 11):

* ``crossTalkHVRx`` ("H to V cross-talk on receive") is delta1, ``crossTalkVHRx`` (V to H on receive) delta2,
  ``crossTalkVHTx`` (V to H on transmit) delta3, ``crossTalkHVTx`` (H to V on transmit) delta4: the schema's order,
  which is also the BPS focuser's Xtalk1..Xtalk4;
* ``channelImbalHVRx`` ("H to V channel imbalance on receive", the V channel's gain over the H channel's) is f1,
  ``channelImbalHVTx`` is f2; 1 is a balanced channel, and epsilon_i = f_i - 1.

The error model of e2esim (Men et al. 2021, Section III) takes each term as zero-mean circular complex Gaussian of
variance V = E|term|^2: the product's value sets V_i = |delta_i|^2 and V_eps,i = |f_i - 1|^2 (the term's mean
power is the product's), the level being the largest of them and each term's share its ``crosstalk_relative``;
the pair correlations stay the instrument's (``crosstalk.correlation_*``, ``channel_imbalance.correlation_*``).
Lists of zeros are what the BPS writes when no constant was configured (``biomass_l1product.py`` defaults): not a
distortion-free instrument, so they are refused; ``crosstalk_from_product: false`` (or
``channel_imbalance_from_product: false``) keeps the scenario's.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from e2esim.errors import UserError
from e2esim.input_files import scenario_relative
from e2esim.instrument.modules import BiomassInstrument
from e2esim.module import fail
from e2esim.params import Param
from e2esim.product_inputs.modules import BiomassProductNoise
from e2esim.products_io import biomass_layout as layout
from e2esim.products_io.biomass_annotation import read_annotation
from e2esim.units import level_db_from_variance

_PARAMS = (
    Param("annotation_file", "str", "the BIOMASS L1 product's annotation XML (its polarimetricDistortion lists), "
          "relative to the scenario file", input_file=True),
    Param("crosstalk_from_product", "bool", "take the crosstalk from the annotation's crossTalkList (false: the "
          "scenario's crosstalk group)", default=True),
    Param("channel_imbalance_from_product", "bool", "take the channel imbalance from the annotation's "
          "channelImbalanceList (false: the scenario's channel_imbalance group)", default=True),
)


def annotation_distortion(annotation: dict) -> tuple:
    """(delta (4,), f (2,)) complex of the system model ``R = [[1, delta2], [delta1, f1]]``, ``T = [[1, delta3],
    [delta4, f2]]`` from a read annotation (``read_annotation``): the schema's crossTalkList order is delta1..delta4
    and channelImbalanceList is (f1, f2) (module docstring)."""
    return np.asarray(annotation["crosstalk"], dtype=complex), np.asarray(annotation["imbalance"], dtype=complex)


def _level_and_shares(variances: np.ndarray) -> tuple:
    level = float(np.max(variances))
    return level, tuple(float(v / level) for v in variances) if level > 0 else (1.0,) * variances.size


class _AnnotationDistortion:
    """Replaces the instrument's crosstalk and channel-imbalance statistics by the annotation's (module docstring)."""

    def setup(self):
        super().setup()
        path = scenario_relative(self.si["annotation_file"], self.location.source)
        try:
            delta, f = annotation_distortion(read_annotation(path))
        except UserError as exc:
            raise fail(self, str(exc), key="annotation_file") from None
        model, description = {}, {}
        for use, group, values, where, names in (
                ("crosstalk_from_product", "crosstalk", delta, layout.CROSSTALK_PATH, "crosstalk"),
                ("channel_imbalance_from_product", "channel_imbalance", f - 1.0, layout.IMBALANCE_PATH,
                 "imbalance")):
            if not self.si[use]:
                continue
            if not np.any((delta if group == "crosstalk" else f) != 0):
                raise fail(self, f"{path}: {layout.ANNOTATION_ROOT}/{where}: every term is 0, which the BPS writes "
                           f"when no {group.replace('_', ' ')} constant was configured, not a distortion-free "
                           "instrument", f"a product whose annotation gives it, or {use}: false (the scenario's "
                           f"{group})", key="annotation_file")
            level, shares = _level_and_shares(np.abs(values) ** 2)
            model.update({f"{names}_level": level, f"{names}_relative": shares})
            description[f"{names}_db"] = (float(level_db_from_variance(level, self.si[group]["convention"]))
                                          if level > 0 else float("-inf"))
        self.model = dataclasses.replace(self.model, **model)
        self.description = dataclasses.replace(self.description, **description)


class BiomassProductDistortion(_AnnotationDistortion, BiomassInstrument):
    """The BIOMASS instrument preset with its crosstalk delta1..delta4 and channel imbalance f1, f2 from a BIOMASS
    L1 product's annotation (``polarimetricDistortion``; module docstring for the convention): V_i = |delta_i|^2,
    V_eps,i = |f_i - 1|^2, the correlations and the noise the preset's (Men et al. 2021, Section III, eqs. 7-8)."""

    type_name = "biomass_product_distortion"
    summary = "BIOMASS instrument preset with the crosstalk and channel imbalance of a BIOMASS L1 annotation"
    params = (*BiomassInstrument.params, *_PARAMS)


class BiomassProductInstrument(_AnnotationDistortion, BiomassProductNoise):
    """``biomass_product_distortion`` with the NESZ of the product's denoising LUT at the site (as
    ``biomass_product_noise``): the annotation's distortion and the LUT's noise together."""

    type_name = "biomass_product_instrument"
    summary = "BIOMASS instrument preset with a BIOMASS L1 product's annotation distortion and LUT noise at a site"
    params = (*BiomassProductNoise.params, *_PARAMS)


__all__ = ["BiomassProductDistortion", "BiomassProductInstrument", "annotation_distortion"]
