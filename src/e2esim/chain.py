"""What flows along the chain: the case state and the typed results the modules add to it.

``CaseState`` is passed through the modules in the order of ``e2esim.module.KINDS``; each module returns
a copy with its field filled (``dataclasses.replace``), like hcipy's ``Wavefront`` passing through an
``OpticalSystem``. Every field is documented with its unit and shape.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from e2esim.distortion.analytic import HVErrorMoments
from e2esim.distortion.montecarlo import MonteCarloErrors
from e2esim.faraday.distribution import FaradayDistribution
from e2esim.instrument.system_errors import SystemErrorModel
from e2esim.retrieval.agb_error import AGBError
from e2esim.scene.covariance import ScatteringCovariance

MODES = ("analytic", "montecarlo", "both")


@dataclass(frozen=True)
class SimulationSettings:
    """The ``simulation`` section: what to compute and with which Monte Carlo sizes.

    mode : "analytic", "montecarlo" or "both".
    seed : root of every random draw (numpy SeedSequence); case i uses the child with spawn key (i,).
    looks : L, independent pixels averaged into one sigma estimate (Men et al. 2021, eq. 17).
    realisations : M, joint system-error and Faraday-rotation realisations.
    noise_realisations : N, noise realisations per system-error realisation.
    keep_samples : store the Monte Carlo error samples in results.h5.
    """

    mode: str = "both"
    seed: int = 0
    looks: int = 100_000
    realisations: int = 10_000
    noise_realisations: int = 1
    keep_samples: bool = True

    @property
    def analytic(self) -> bool:
        return self.mode in ("analytic", "both")

    @property
    def montecarlo(self) -> bool:
        return self.mode in ("montecarlo", "both")


@dataclass(frozen=True)
class InstrumentDescription:
    """How the instrument states its errors, for reports: levels in dB and their convention.

    crosstalk_db, imbalance_db : specified levels (dB) under ``convention``. nesz_db : NESZ (dB).
    centre_frequency_hz, bandwidth_hz : radar centre frequency and bandwidth (Hz). name : label.
    """

    name: str
    crosstalk_db: float
    imbalance_db: float
    convention: str
    nesz_db: float
    centre_frequency_hz: float
    bandwidth_hz: float


@dataclass(frozen=True)
class BackscatterError:
    """Error of the estimated sigma_hv (m^2/m^2), from the ``propagation`` module.

    sigma_hv : true sigma_hv of the scene (m^2/m^2).
    analytic : mean, variance and contributions (``HVErrorMoments``), or None.
    montecarlo : simulated errors (``MonteCarloErrors``), or None.
    gaussianity : skewness, excess kurtosis, normality p-value and KS distance of the simulated errors.
    form, looks, reference : settings of the analytic model, so later modules (requirement margins,
        trade-off curves) can re-evaluate it at other error levels.
    budget : random-error budget of the backscattering coefficient added by a later propagation module
        (speckle, noise, temporal variability, calibration; Ahmed et al. 2014), or None.
    notes : remarks for the report (e.g. why the analytic model was not used).
    """

    sigma_hv: float
    analytic: HVErrorMoments | None = None
    montecarlo: MonteCarloErrors | None = None
    gaussianity: dict | None = None
    form: str = "complete"
    looks: int | None = None
    reference: str = "scene"
    budget: Any = None
    notes: tuple = ()


@dataclass(frozen=True)
class RequirementVerdict:
    """Verdict of one requirement for one case.

    name : label of the requirement. passed : verdict. value : the quantity checked, limit : its bound,
    margin : how far inside the bound (positive passes), all in ``unit``. basis : "analytic" or
    "montecarlo". details : further numbers (exceedance probabilities, cross-checks, level margins in dB).
    curves : trade-off curves and other arrays (name -> ndarray), possibly empty.
    dominant : the error source whose removal would reduce ``value`` most ("" if not attributed).
    """

    name: str
    passed: bool
    value: float
    limit: float
    margin: float
    unit: str
    basis: str
    details: dict = field(default_factory=dict)
    curves: dict = field(default_factory=dict)
    dominant: str = ""


@dataclass(frozen=True)
class CaseState:
    """State of one sweep case as it passes along the chain.

    index : case number in the sweep. inputs : the sweep values of this case (dotted key -> value).
    settings : the simulation settings. rng : the case's own random generator.
    geometry : acquisition geometry (orbit module), or None.
    faraday : Faraday-rotation distribution (ionosphere module).
    scene : scattering covariance (scene module).
    system : system-error model after the instrument (and calibration) modules.
    raw_system : the instrument's system-error model before calibration.
    calibration : what the calibration module(s) did (their own result object), or None.
    instrument : how the instrument states its specification (for reports).
    backscatter : sigma_hv error (propagation module).
    agb : relative AGB error (retrieval module).
    verdicts : requirement verdicts, in the order of the scenario's ``requirements``.
    """

    index: int
    inputs: dict
    settings: SimulationSettings
    rng: np.random.Generator
    geometry: Any = None
    faraday: FaradayDistribution | None = None
    scene: ScatteringCovariance | None = None
    system: SystemErrorModel | None = None
    raw_system: SystemErrorModel | None = None
    calibration: Any = None
    instrument: InstrumentDescription | None = None
    backscatter: BackscatterError | None = None
    agb: AGBError | None = None
    verdicts: tuple = ()

    def with_(self, **changes) -> "CaseState":
        """A copy with some fields changed (cheaper than dataclasses.replace: no re-validation to do)."""
        new = copy.copy(self)
        for name, value in changes.items():
            if name not in _CASE_STATE_FIELDS:
                raise TypeError(f"CaseState has no field {name!r}")
            object.__setattr__(new, name, value)
        return new


_CASE_STATE_FIELDS = frozenset(CaseState.__dataclass_fields__)
