"""``AGBError`` for a block of sweep cases: fields with a leading case axis, the same element-wise answers.

``AGBError``'s analytic answers (quantiles, exceedance, RMSE, mean, contribution statistics) are element-wise in
its fields, so the same class answers for a block when its fields are arrays over the cases; this subclass adds
what a block product needs (``e2esim.block.Batched``): the one-case ``AGBError`` of any case, taking and joining
cases, and the output scalars of every case.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from e2esim.block import Batched
from e2esim.retrieval.agb_error import AGBContribution, AGBError


@dataclass(frozen=True)
class AGBErrorBlock(Batched, AGBError):
    """Relative AGB errors of B cases (analytic): exponent, sigma_hv, error_mean and error_sd of shape (B,);
    contributions with (B,) means and variances; ``error_model`` a block error model or None."""

    def __len__(self) -> int:
        return len(self.exponent)

    def item(self, i: int) -> AGBError:
        return AGBError(float(self.exponent[i]), float(self.sigma_hv[i]), _at(self.error_mean, i),
                        _at(self.error_sd, i), None, self.mapping,
                        tuple(AGBContribution(c.name, c.group, float(c.relative_mean[i]), float(c.relative_variance[i]),
                                              c.description, None if c.uncertainty is None else c.uncertainty.item(i))
                              for c in self.contributions),
                        tuple((basis, float(np.asarray(f)[i])) for basis, f in self.saturated_fraction),
                        None if self.error_model is None else self.error_model.item(i))

    def take(self, positions) -> AGBErrorBlock:
        return dataclasses.replace(
            self, exponent=self.exponent[positions], sigma_hv=self.sigma_hv[positions],
            error_mean=self.error_mean[positions], error_sd=self.error_sd[positions],
            contributions=tuple(dataclasses.replace(c, relative_mean=c.relative_mean[positions],
                                                    relative_variance=c.relative_variance[positions],
                                                    uncertainty=None if c.uncertainty is None
                                                    else c.uncertainty.take(positions))
                                for c in self.contributions),
            saturated_fraction=tuple((b, np.asarray(f)[positions]) for b, f in self.saturated_fraction),
            error_model=None if self.error_model is None else self.error_model.take(positions))

    @classmethod
    def concatenate(cls, parts: list) -> AGBErrorBlock:
        first = parts[0]

        def joined(get):
            return np.concatenate([np.asarray(get(p)) for p in parts])

        return dataclasses.replace(
            first, exponent=joined(lambda p: p.exponent), sigma_hv=joined(lambda p: p.sigma_hv),
            error_mean=joined(lambda p: p.error_mean), error_sd=joined(lambda p: p.error_sd),
            contributions=tuple(dataclasses.replace(c, relative_mean=joined(lambda p, k=k: p.contributions[k]
                                                                            .relative_mean),
                                                    relative_variance=joined(lambda p, k=k: p.contributions[k]
                                                                             .relative_variance),
                                                    uncertainty=None if c.uncertainty is None
                                                    else type(c.uncertainty).concatenate(
                                                        [p.contributions[k].uncertainty for p in parts]))
                                for k, c in enumerate(first.contributions)),
            saturated_fraction=tuple((b, joined(lambda p, k=k: p.saturated_fraction[k][1]))
                                     for k, (b, _) in enumerate(first.saturated_fraction)),
            error_model=None if first.error_model is None else type(first.error_model).concatenate(
                [p.error_model for p in parts]))

    def scalar_columns(self) -> dict:
        n = len(self)
        return {name: np.broadcast_to(np.asarray(value, dtype=float), (n,)) for name, value in self.scalars().items()}

    def source_groups(self) -> dict:
        return {c.name: c.group for c in self.contributions}


def _at(values, i: int):
    return None if values is None else float(values[i])


__all__ = ["AGBErrorBlock"]
