"""``combined_agb_error`` for a block of analytic sweep cases: the same sums, element-wise over the case axis.

The power law's forward for a block (``PowerLawRetrieval._block_error``) combines, for every case of a block at once,
the systematic error of the propagation's block error model, the random-error budget of each case (a ``Factor``:
its terms read once per distinct budget) and the regression term, exactly as ``combine.combined_agb_error`` does
for one case: the same contributions in the same order, the same operations on the same numbers, so each case
gets bitwise the ``AGBError`` the per-case engine makes (tests/test_batched_engine.py).
"""

from __future__ import annotations

import numpy as np

from e2esim.block import CaseRandom, Factor
from e2esim.case import Case
from e2esim.distinct import distinct_rows
from e2esim.errors import ConfigError
from e2esim.retrieval.agb_error import AGBContribution, AGBError
from e2esim.retrieval.campaign_ensemble import RegressionUncertainty
from e2esim.retrieval.combine import budget_contributions, random_total_variance


def combined_agb_error_block(model, budget, exponent, regression=None) -> AGBError | None:
    """The ``AGBError`` of B analytic cases: ``model`` the block's error model (``Batched``, analytic),
    ``budget`` the block's budgets (``Factor``) or None, ``exponent`` (B,), ``regression`` an ``AGBContribution``
    with (B,) fields or None. None when the budgets' terms differ between cases (then case by case)."""
    s = np.asarray(model.value, dtype=float)
    systematic = tuple(AGBContribution(name, "systematic", c.mean / s, c.variance / s**2, c.description)
                       for name, c in model.contributions().items())
    random_, rand_var = (), 0.0
    if budget is not None:
        used = np.unique(budget.index)
        terms = {int(k): _budget_terms(budget.values[int(k)]) for k in used}
        names = {names for names, _ in terms.values()}
        if len(names) != 1:
            return None
        table = np.zeros((int(used.max()) + 1, len(next(iter(names))) + 1))
        for k, (_, variances) in terms.items():
            table[k] = variances
        variances = table[budget.index]  # (B, terms + 1): each term's relative variance, then their total
        random_ = tuple(AGBContribution(name, "random", np.zeros(len(s)), variances[:, k], description)
                        for k, (name, description) in enumerate(next(iter(names))))
        rand_var = variances[:, -1]
    reg = (regression,) if regression is not None else ()
    reg_var = regression.relative_variance if regression is not None else 0.0
    m = model.current()
    var = np.asarray(m.variance, dtype=float) + s**2 * (rand_var + reg_var)
    return AGBError(np.asarray(exponent, dtype=float), s, np.asarray(m.mean, dtype=float),
                         np.sqrt(np.maximum(var, 0.0)), None, None, systematic + random_ + reg, error_model=model)


def _budget_terms(budget) -> tuple:
    """((name, description) of each budget term, [the relative variance of each, then of their total]), as
    ``combine.combined_agb_error`` sums them."""
    contributions = budget_contributions(budget)
    return (tuple((c.name, c.description) for c in contributions),
            [c.relative_variance for c in contributions] + [random_total_variance(budget, contributions)])


def stable_regression(stage, block, sigma, agb, exponent, model_of) -> AGBContribution | None:
    """The regression term of every case of ``block`` (``stage.regression``), made once per distinct (sigma, AGB,
    exponent), when it draws nothing from the case's own generator: it is then the same for every case with
    those values. None when it draws (each case has its own draw: the per-case engine makes them) or fails
    (the per-case engine says why). ``model_of(agb, sigma, exponent)`` is the retrieval model through the case's
    truth."""
    rows = np.stack([np.asarray(v, dtype=float).view(np.int64) for v in (sigma, agb, exponent)], -1)
    _, first, inverse = distinct_rows(rows)
    made = []
    for k in first:
        index = int(block.indices[k])
        rng = CaseRandom(block.settings.seed, block.settings.stream_of(index))
        case = Case(index=index, inputs={}, settings=block.settings, rng=rng, services=block.services)
        a, s, p = float(agb[k]), float(sigma[k]), float(exponent[k])
        try:
            term = stage.regression(case, model_of(a, s, p), a)
        except ConfigError:
            return None
        if rng.uses:
            return None
        made.append(term)
    inverse = np.ravel(inverse)
    first_term = made[0]
    if any((t.name, t.group, t.description) != (first_term.name, first_term.group, first_term.description)
           for t in made):
        return None
    sampled = [t.uncertainty is not None for t in made]
    if any(sampled) and not all(sampled):
        return None
    uncertainty = RegressionUncertainty.gathered([t.uncertainty for t in made], inverse) if all(sampled) else None
    return AGBContribution(first_term.name, first_term.group,
                           np.asarray([t.relative_mean for t in made], dtype=float)[inverse],
                           np.asarray([t.relative_variance for t in made], dtype=float)[inverse],
                           first_term.description, uncertainty)


def gather_agb(stage, scene: Factor) -> np.ndarray | None:
    """The AGB (t/ha) of every case the retrieval applies its error at (``_Retrieval.case_agb``): the stage's
    ``agb_t_ha`` or the scene's; None when a scene states none (the per-case engine says so)."""
    fixed = stage.si.get("agb_t_ha")
    if fixed:
        return np.full(len(scene), float(fixed))
    agb = scene.gather(lambda v: np.nan if v.agb_t_ha is None else float(v.agb_t_ha), name="scene AGB")
    return None if np.isnan(agb).any() else agb
