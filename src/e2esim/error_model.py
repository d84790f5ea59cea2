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
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np


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
    """

    channel: str = "hv"
    unavailable: str | None = None
    includes_speckle: bool = False
    notes: tuple = ()

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
    def without(self, source: str) -> "ErrorModel":
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
