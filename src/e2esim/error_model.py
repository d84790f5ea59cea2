"""The interface between a propagation stage and everything after it: an error model of a backscatter estimate.

A propagation stage provides ``backscatter.error``, an ``ErrorModel``. Later stages ask it questions and
never re-run the physics of an earlier stage themselves, so a plug-in propagation module gets retrieval,
requirement margins, attribution and trade-off curves for free:

* ``moments(**levels)``: mean and variance of the error at other error levels (a level is a variance or a
  power, named in ``levels``; arrays broadcast, so curves and root finding take one call);
* ``without(source)``: the same model with one error source removed (``sources``);
* ``contributions()``: the share of each source in the mean and variance, adding up to the total.

A model that cannot answer (for example a Monte Carlo only model, when the errors are too large for an
expansion) says why in ``unavailable``; the stages that need the answer then report that reason.

Several channels estimated from the same data have correlated errors: a ``MultiChannelErrorModel`` answers
the same questions for all of them at once (mean vector, covariance matrix) and is, for every single-channel
consumer, the error model of its primary channel; ``ChannelView`` and other ``DerivedErrorModel``s turn it
into single-channel models (docs/architecture.md, "Several channels").
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from e2esim.derived import derived_values, knowing


class ErrorModelUnavailable(Exception):
    """The error model cannot answer this question; the message says why (shown in reports)."""


@dataclass(frozen=True)
class Moments:
    """Mean and variance of an error (m^2/m^2 and (m^2/m^2)^2), any broadcast shape."""

    mean: np.ndarray
    variance: np.ndarray

    @property
    def sd(self) -> np.ndarray:
        return np.sqrt(self.variance)


@dataclass(frozen=True)
class Contribution:
    """One source's share of an error: its mean and variance (m^2/m^2, (m^2/m^2)^2; the variance may be
    negative for an increment over another source), with a one-line description."""

    mean: float
    variance: float
    description: str = ""


class ErrorModel(ABC):
    """Error ``e = sigma_hat - sigma`` of the estimate of one backscattering coefficient.

    Attributes a subclass provides:

    channel : the channel estimated ("hv", ...). value : the true coefficient sigma (m^2/m^2).
    levels : {level name: current value} of the error levels ``moments`` accepts (variances of the
        crosstalk and channel-imbalance terms, the noise power, ...; linear units).
    sources : names of the error sources ``without`` can remove (all of them, active or not).
    unavailable : why ``moments`` cannot be evaluated, or None when it can.
    includes_speckle : the error already counts speckle over the looks (so a random-error budget must not
        count it again).
    notes : remarks for the report (e.g. why the analytic model was not used).
    validity : the measured validity range of the analytic moments (``e2esim.distortion.validity.ValidityRange``:
        margins and trade-off curves search the levels up to its edge), or None when not known.
    costly_levels : levels whose every value costs the model a computation of its own (new quadrature nodes):
        a margin's search bisects its scan grid over them instead of evaluating all of it
        (``e2esim.requirements.level_search.first_failing_level``).
    levels_lead_sources : the sources that only set a level to zero come first in ``sources``, and a model with one
        of them removed shares the node terms of the model it was made from: ``subsets_of`` then makes each subset's
        model from its parent by the subset's first source, so that most share their parent's (the multi-pass
        models). The same models either way, only made in another order.
    """

    channel: str = "hv"
    unavailable: str | None = None
    includes_speckle: bool = False
    notes: tuple = ()
    validity = None
    costly_levels: tuple = ()
    levels_lead_sources: bool = False

    @property
    @abstractmethod
    def value(self) -> float:
        """The true backscattering coefficient sigma (m^2/m^2)."""

    @property
    @abstractmethod
    def levels(self) -> dict:
        """{level name: current value} of the scalable error levels."""

    @property
    @abstractmethod
    def sources(self) -> tuple:
        """Names of the error sources ``without`` can remove."""

    @abstractmethod
    def moments(self, **levels):
        """Mean and variance of the error with some levels replaced (broadcast); an object with ``mean``,
        ``variance`` and ``sd``. Raises ``ErrorModelUnavailable`` when ``unavailable``."""

    @abstractmethod
    def without(self, source: str) -> ErrorModel:
        """The same model with ``source`` removed; the model itself when the source is not active."""

    @abstractmethod
    def contributions(self) -> dict:
        """{name: Contribution}, adding up to the mean and variance of ``moments()``."""

    def relative_samples(self) -> np.ndarray | None:
        """Monte Carlo samples of the relative error e / sigma, shape (M, N), or None."""
        return None

    def samples(self) -> np.ndarray | None:
        """Monte Carlo samples of the error e (m^2/m^2), shape (M, N), or None."""
        rel = self.relative_samples()
        return None if rel is None else rel * self.value

    def current(self):
        """``moments()`` at the model's own levels (computed once by implementations that cache it)."""
        return self.moments()

    def check_available(self) -> None:
        if self.unavailable is not None:
            raise ErrorModelUnavailable(self.unavailable)

    def scalars(self) -> dict:
        """Output scalars of the model (summary.json, results.h5); names documented in docs/output-format.md."""
        return {}

    @cached_property
    def source_subsets(self) -> tuple:
        """(names, means, variances, active): the sources active in some case, the mean and variance of the error
        with only the sources of each subset of them switched on ((2^k,) + the case shape, subset mask m: bit j set
        where source j is on; m = 2^k - 1 is the model itself) and where each source is active (True: in every
        case, or a per-case bool array). The Shapley split's 2^k evaluations (``e2esim.requirements.shapley``),
        made once per model object: the requirements of a case ask the same model. See ``subsets_of``."""
        return subsets_of(self)


# Several channels ----------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class JointMoments:
    """Mean vector and covariance matrix of the errors of several channels: mean (..., C), covariance
    (..., C, C), in m^2/m^2 and (m^2/m^2)^2, channels in ``channels`` order."""

    channels: tuple
    mean: np.ndarray
    covariance: np.ndarray

    @property
    def variance(self) -> np.ndarray:
        return np.diagonal(self.covariance, axis1=-2, axis2=-1)


@dataclass(frozen=True)
class JointContribution:
    """One source's share of the errors of several channels: mean (C,) and covariance (C, C)."""

    mean: np.ndarray
    covariance: np.ndarray
    description: str = ""


@dataclass(frozen=True, eq=False, kw_only=True)
class ModelEvaluation:
    """The keyword-only fields the built-in error models share (the HV, polarimetric and multi-pass models):
    how their analytic moments are evaluated and what checked them.

    looks : L, or None for L -> infinity. reference : "scene" (the error of the estimate against the scene's own
    covariance) or "population" (speckle over the looks counted). montecarlo : the simulated errors of the
    model's kind, or None. gaussianity : statistics of the simulated HV errors (Men et al. 2021, Fig. 2), or
    None. notes, unavailable : as ``ErrorModel``. What a model evaluates is derived once per object, as its
    ``functools.cached_property``s (docs/architecture.md, "Caching"); ``knowing`` sets those its maker has.
    """

    looks: int | None = None
    reference: str = "scene"
    montecarlo: object = None
    gaussianity: dict | None = None
    notes: tuple = ()
    unavailable: str | None = None

    def with_montecarlo(self, montecarlo, gaussianity):
        """The same model with its simulated errors, knowing what this one derived (none of it reads the samples)."""
        return knowing(replace(self, montecarlo=montecarlo, gaussianity=gaussianity), **derived_values(self))


class MultiChannelErrorModel(ErrorModel):
    """Errors ``e_p = sigma_hat_p - sigma_p`` of several channels estimated from the same data, jointly.

    The channel errors share their sources (the same crosstalk, imbalance and Faraday rotation act on all), so
    they are correlated; a multi-channel retrieval needs their covariance. The multi-channel questions:

    * ``joint_moments(**levels)``: a ``JointMoments``-like object (``mean`` (..., C), ``covariance``
      (..., C, C)) at other levels, broadcast like ``moments``; ``current_joint()`` at the model's own;
    * ``joint_contributions()``: {name: ``JointContribution``}, adding up to the joint mean and covariance;
    * ``joint_relative_samples()``: Monte Carlo samples of e_p / sigma_p, shape (M, N, C), or None;
    * ``speckle_correlation()``: how the channels' speckle correlates over the looks, or None (the scene's);
    * ``channel_view(name)``: one channel as a single-channel ``ErrorModel`` (verdicts, margins, trade-off
      curves through the single-channel requirement code);
    * ``without(source)`` returns a ``MultiChannelErrorModel``.

    It is also an ``ErrorModel`` of its ``channel`` (the primary channel, HV by default), so every
    single-channel consumer (power-law retrieval, requirements, reports) works with it unchanged.
    """

    channels: tuple = ("hh", "hv", "vv")

    @property
    @abstractmethod
    def values(self) -> np.ndarray:
        """The true coefficients sigma_p (m^2/m^2), shape (C,)."""

    @abstractmethod
    def joint_moments(self, **levels):
        """Mean vector and covariance matrix of the channel errors with some levels replaced (broadcast)."""

    @abstractmethod
    def joint_contributions(self) -> dict:
        """{name: JointContribution}, adding up to ``current_joint()``."""

    def current_joint(self):
        """``joint_moments()`` at the model's own levels (implementations cache it)."""
        return self.joint_moments()

    def joint_relative_samples(self) -> np.ndarray | None:
        """Monte Carlo samples of e_p / sigma_p, shape (M, N, C), or None."""
        return None

    def speckle_correlation(self) -> np.ndarray | None:
        """(C, C) correlation of the channels' speckle over the looks when the estimate is not a single image
        (e.g. a combination of passes), or None: then the intensity correlation of the scene's covariance."""
        return None

    def index(self, channel: str) -> int:
        if channel not in self.channels:
            raise KeyError(f"unknown channel {channel!r}; channels: {', '.join(self.channels)}")
        return self.channels.index(channel)

    def channel_view(self, channel: str) -> ChannelView:
        """Channel ``channel`` as a single-channel ``ErrorModel``."""
        return ChannelView(self, channel)

    # the single-channel interface: the primary channel
    @property
    def value(self) -> float:
        return float(self.values[self.index(self.channel)])

    def moments(self, **levels) -> Moments:
        return _channel_moments(self.joint_moments(**levels), self.index(self.channel))

    def current(self) -> Moments:
        return _channel_moments(self.current_joint(), self.index(self.channel))

    def contributions(self) -> dict:
        i = self.index(self.channel)
        return {name: Contribution(float(c.mean[i]), float(c.covariance[i, i]), c.description)
                for name, c in self.joint_contributions().items()}

    def relative_samples(self) -> np.ndarray | None:
        rel = self.joint_relative_samples()
        return None if rel is None else rel[..., self.index(self.channel)]


def _channel_moments(joint, i: int) -> Moments:
    # a truncated expansion evaluated far beyond its range (root finding scans levels up to 0 dB) can give a
    # slightly negative variance: read it as 0
    return Moments(np.asarray(joint.mean)[..., i], np.clip(np.asarray(joint.covariance)[..., i, i], 0.0, None))


def _of_source(name: str) -> property:
    """A read-only property that is the source model's attribute ``name``."""
    return property(lambda self: getattr(self.source, name), doc=f"The source model's ``{name}``.")


class DerivedErrorModel(ErrorModel):
    """A single-channel error model computed from a ``MultiChannelErrorModel``: one of its channels
    (``ChannelView``) or a function of all of them (e.g. the log-AGB error of a multi-channel retrieval).
    Levels, sources and availability are the source model's; subclasses say how the joint moments and
    samples reduce (``reduce``, ``reduce_samples``) and how a variant is rebuilt (``rebuilt``)."""

    def __init__(self, source: MultiChannelErrorModel):
        self.source = source

    @abstractmethod
    def reduce(self, joint) -> Moments:
        """Mean and variance of this error from the joint moments (any broadcast shape)."""

    @abstractmethod
    def reduce_samples(self, relative: np.ndarray) -> np.ndarray:
        """Samples of this relative error from relative channel errors (M, N, C)."""

    @abstractmethod
    def rebuilt(self, source: MultiChannelErrorModel) -> DerivedErrorModel:
        """The same reduction of another source model."""

    levels = _of_source("levels")
    sources = _of_source("sources")
    unavailable = _of_source("unavailable")
    includes_speckle = _of_source("includes_speckle")
    notes = _of_source("notes")
    validity = _of_source("validity")
    costly_levels = _of_source("costly_levels")
    levels_lead_sources = _of_source("levels_lead_sources")

    def moments(self, **levels) -> Moments:
        self.check_available()
        return self.reduce(self.source.joint_moments(**levels))

    def current(self) -> Moments:
        self.check_available()
        return self.reduce(self.source.current_joint())

    def without(self, source: str) -> ErrorModel:
        variant = self.source.without(source)
        return self if variant is self.source else self.rebuilt(variant)

    def relative_samples(self) -> np.ndarray | None:
        rel = self.source.joint_relative_samples()
        return None if rel is None else self.reduce_samples(rel)


class ChannelView(DerivedErrorModel):
    """One channel of a ``MultiChannelErrorModel`` as a single-channel ``ErrorModel``."""

    def __init__(self, source: MultiChannelErrorModel, channel: str):
        super().__init__(source)
        self.channel = channel
        self._i = source.index(channel)

    @property
    def value(self) -> float:
        return float(self.source.values[self._i])

    def reduce(self, joint) -> Moments:
        return _channel_moments(joint, self._i)

    def reduce_samples(self, relative: np.ndarray) -> np.ndarray:
        return relative[..., self._i]

    def rebuilt(self, source: MultiChannelErrorModel) -> ChannelView:
        return ChannelView(source, self.channel)

    def contributions(self) -> dict:
        return {name: Contribution(float(c.mean[self._i]), float(c.covariance[self._i, self._i]), c.description)
                for name, c in self.source.joint_contributions().items()}


def subsets_of(model: ErrorModel) -> tuple:
    """``ErrorModel.source_subsets``: each subset's model built by removals one at a time (``without``) and evaluated
    once. A source whose removal changes nothing is left out: the model itself (not active), or a variant that marks
    it ``inactive`` in every case of a block (a case alone leaves it out the same way). Where a source is not active
    in some cases, its removal changes nothing there, exactly: those cases keep the smaller subset's moments."""
    own, inactive = [], {}
    for name in model.sources:
        variant = model.without(name)
        off = getattr(variant, "inactive", None)
        if variant is not model and not (off is not None and np.all(off)):
            own.append(name)
            inactive[name] = off
    active = tuple(True if inactive[name] is None else ~np.asarray(inactive[name], dtype=bool) for name in own)
    k = len(own)
    variants = {0: model}  # by the bit mask of the sources taken away
    first = getattr(model, "levels_lead_sources", False)  # a subset made by its first source, else by its last
    for removed in range(1, 2**k):
        bit = (removed & -removed).bit_length() - 1 if first else removed.bit_length() - 1
        variants[removed] = variants[removed & ~(1 << bit)].without(own[bit])
    full = 2**k - 1
    means, variances = [], []
    for on in range(2**k):  # ascending: a subset's smaller subsets are done first
        m = variants[full & ~on].current()
        # a truncated expansion far from its own levels can give a slightly negative variance: read it as 0 (as
        # _channel_moments does)
        mean, var = np.asarray(m.mean, dtype=float), np.clip(np.asarray(m.variance, dtype=float), 0.0, None)
        for bit, name in enumerate(own):
            off = inactive[name]
            if on >> bit & 1 and off is not None and np.any(off):
                mean = np.where(off, means[on & ~(1 << bit)], mean)
                var = np.where(off, variances[on & ~(1 << bit)], var)
        means.append(mean)
        variances.append(var)
    shape = np.broadcast_shapes(*(np.shape(x) for x in means + variances))
    return (tuple(own), np.stack([np.broadcast_to(x, shape) for x in means]),
            np.stack([np.broadcast_to(x, shape) for x in variances]), active)
