"""How sure a verdict is: the standard error of its value, whether its margin lies inside that uncertainty, and
whether the analytic model and the Monte Carlo agree.

Every verdict's ``details`` get (docs/output-format.md):

* ``<basis>.value`` and ``<basis>.value_standard_error`` for each basis computed (analytic, montecarlo), in the
  verdict's unit, and ``value_standard_error``, that of the basis the verdict uses. The Monte Carlo's standard
  error is its sampling error (``e2esim.retrieval.sampling_error``); both bases add the error of the sampled
  variance terms (the regression's expectation over simulated campaigns). An analytic value without sampled
  terms has none (0): it is exact for its model;
* ``margin_within_uncertainty``: 1 where the margin is inside the value's 95 % interval, |margin| <=
  1.96 SE (another seed or more samples could flip the verdict), else 0;
* ``basis_disagreement``: where both bases are computed and differ by more than ``Z_DISAGREE`` standard errors
  of the difference (the Monte Carlo's sampling error: the sampled terms enter both alike), 1 when the Monte
  Carlo's mean and SD of the relative sigma error agree with the analytic ones, so that the difference is the
  shape of the distribution (a non-Gaussian tail the analytic Gaussian quantile does not have: e.g. the gamma
  law of the speckle and noise in the Monte Carlo), 2 when those moments differ too (the analytic moments'
  approximation); 0 otherwise. The verdict keeps its basis (``basis_of``): the flag says which one it used.

A verdict of one case also gets a note saying so; the command line and the top of the report count both flags
over the cases (``e2esim.report.uncertainty``).
"""

from __future__ import annotations

import numpy as np

from e2esim.case_values import plain
from e2esim.retrieval.sampling_error import Z95

Z_DISAGREE = 3.0
"""Analytic and Monte Carlo values disagree when they differ by more than this many standard errors (0.3 %
of agreeing cases are flagged by chance)."""
AGREE, SHAPE, MOMENTS = 0.0, 1.0, 2.0
"""``basis_disagreement`` codes: none; the distributions' shapes differ; their moments differ."""
_RELATIVE_TIE = 1e-9  # values this close (relative) are equal whatever their standard error (0 at a cap)


def verdict_uncertainty(agb, basis: str, values: dict, errors: dict, sampling: float | None, margin, unit: str,
                        applies=None) -> tuple[dict, tuple]:
    """(details, notes) of a verdict (module docstring).

    agb : the checked ``AGBError``. basis : the verdict's basis. values, errors : basis -> value and its
    standard error (verdict unit). sampling : the Monte Carlo value's sampling standard error alone (None
    without Monte Carlo). margin : the verdict's margin. applies : where the requirement applies (None: all).
    """
    details = {}
    for b, v in values.items():
        details[f"{b}.value"] = v
        details[f"{b}.value_standard_error"] = errors[b]
    se = errors[basis]
    inside = (np.abs(np.asarray(margin, dtype=float)) <= Z95 * np.asarray(se)) & (np.asarray(se) > 0)
    if applies is not None:
        inside = inside & np.asarray(applies, dtype=bool)
    details["value_standard_error"] = se
    details["margin_within_uncertainty"] = plain(inside.astype(float))
    code = np.zeros(np.shape(inside))
    if "analytic" in values and "montecarlo" in values and sampling is not None:
        code = np.where(_disagree(values["analytic"], values["montecarlo"], sampling),
                        SHAPE if _moments_agree(agb) else MOMENTS, AGREE)
    details["basis_disagreement"] = plain(code)
    notes = ()
    if np.ndim(inside) == 0:  # one case: say it in words too (a block's notes are shared by its cases)
        notes = tuple(n for n in (margin_note(margin, se, unit) if inside else None,
                                  disagreement_note(code, values, errors, basis, unit)) if n)
    return details, notes


def margin_note(margin, se, unit: str) -> str:
    return (f"the margin {float(margin):.3g} {unit} is inside the value's 95 % uncertainty (+-{Z95 * float(se):.2g} "
            f"{unit}, 1.96 standard errors): another seed or more samples could flip the verdict")


def disagreement_note(code, values: dict, errors: dict, basis: str, unit: str) -> str | None:
    if float(code) == AGREE:
        return None
    a, m = values["analytic"], values["montecarlo"]
    return (f"analytic {a:.4g} {unit} and Monte Carlo {m:.4g} +- {errors['montecarlo']:.2g} {unit} disagree by more "
            f"than {Z_DISAGREE:g} standard errors; the verdict uses the {basis} value ({basis_reason(basis)}). "
            + DISAGREEMENT_CAUSES[float(code)])


DISAGREEMENT_CAUSES = {
    SHAPE: "The Monte Carlo's mean and SD of the sigma error agree with the analytic ones: the difference is the shape "
           "of the distribution, a skew or tail the analytic Gaussian does not have (e.g. the gamma law of the Monte "
           "Carlo's speckle and noise, or the quadratic form of large system errors).",
    MOMENTS: "The Monte Carlo's mean or SD of the sigma error differs from the analytic one: the analytic moments' "
             "approximation does not hold here (docs/theory/co-pol-error.md).",
}


def basis_reason(basis: str) -> str:
    return ("basis auto or analytic: the analytic model when it is computed" if basis == "analytic" else
            "basis montecarlo, or no analytic model")


def _disagree(a, m, sampling):
    a, m = np.asarray(a, dtype=float), np.asarray(m, dtype=float)
    diff = np.abs(a - m)
    tie = diff <= _RELATIVE_TIE * np.maximum(np.abs(a), 1.0)
    return (diff > Z_DISAGREE * np.asarray(sampling, dtype=float)) & ~tie & np.isfinite(diff)


def _moments_agree(agb) -> bool:
    """Whether the Monte Carlo's mean and SD of the relative sigma error are within ``Z_DISAGREE`` standard errors
    of the analytic ones."""
    if not agb.sample_moments or agb.error_mean is None or np.ndim(agb.error_mean):
        return True
    mean, mean_se, sd, sd_se = agb.sample_moments
    s = float(agb.sigma_hv)
    return (abs(mean - float(agb.error_mean) / s) <= Z_DISAGREE * mean_se
            and abs(sd - float(agb.error_sd) / s) <= Z_DISAGREE * sd_se)


def largest_side(values: list, errors: list):
    """(value, its standard error) of the side with the largest value (element-wise for a block)."""
    if all(np.ndim(v) == 0 for v in values):
        k = int(np.argmax(values))
        return values[k], errors[k]
    arrays = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (*values, *errors)))
    stacked, se = np.stack(arrays[:len(values)]), np.stack(arrays[len(values):])
    k = np.argmax(stacked, axis=0)[None]
    return np.take_along_axis(stacked, k, 0)[0], np.take_along_axis(se, k, 0)[0]

