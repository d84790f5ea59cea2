"""Two figures of a NISAR product's ``metadata/calibrationInformation`` as terms of the per-pixel budget (issue 26;
docs/real-data.md, "NISAR's RFI likelihood and crosstalk tables"):

* ``rfiLikelihood`` (per polarisation, in [0, 1], NaN where RFI detection was skipped). isce3's RSLC writer
  (``nisar/products/writers/SLC.py``, ``set_rfi_results``) stores the pulse-weighted mean of the detector's
  per-block likelihoods; its earlier description was "Ratio of number of CPIs detected with RFI eigenvalues over
  that of total number of CPIs", the later "Severity of RFI contamination in the data, 0 lowest, 1 highest". e2esim
  reads it as the share of the aperture time whose interference was mitigated and counts it as the RFI term's
  blanked time f_t (``FixedGain``: every channel's intensity times g = 1 - f_t, not restored; docs/theory/rfi.md),
  the largest over the polarisations as for BIOMASS (one estimate combines the channels). This is an upper bound:
  the slow-time eigenvalue mitigation removes the interference's subspace of a coherent processing interval, not
  the whole interval. A polarisation whose detection was skipped (NaN) adds nothing, and the attribute
  ``product_rfi_detection_skipped`` names it: its interference is unknown, not absent.
* the crosstalk tables ``crosstalk/{tx,rx}{Horizontal,Vertical}Crosspol`` against ``crosstalk/slantRange``: each
  table is interpolated linearly (real and imaginary parts; the end values held beyond the axis, as
  ``numpy.interp``) at each pixel's slant range. A pixel where all four interpolated values are zero lies where the
  processor applied no crosstalk correction: its full (raw) crosstalk counts; elsewhere the scenario's residual after
  calibration counts (the reading of the tables e2esim already gives a whole product: non-zero = corrected).
"""

from __future__ import annotations

import numpy as np


def rfi_blanked_fraction(likelihoods: dict) -> tuple:
    """(f_t, facts) from {polarisation: rfiLikelihood}: the largest finite likelihood (0 where none is finite) and
    the attributes that report it (module docstring)."""
    finite = {c: v for c, v in likelihoods.items() if np.isfinite(v)}
    fraction = max(finite.values(), default=0.0)
    facts = {"rfi_blanked_fraction_counted": fraction,
             "rfi_blanked_fraction_source": "the largest rfiLikelihood over the polarisations"}
    skipped = sorted(c for c in likelihoods if c not in finite)
    if skipped:
        facts["product_rfi_detection_skipped"] = ", ".join(skipped)
    return fraction, facts


def crosstalk_corrected_at(axis: np.ndarray, tables, slant_range: np.ndarray) -> np.ndarray:
    """Whether crosstalk was corrected at each slant range (m) of ``slant_range``: any of the four ``tables``
    (complex, on ``axis``, m) non-zero there once interpolated (module docstring). Same shape as slant_range."""
    order = np.argsort(axis)
    corrected = np.zeros(np.shape(slant_range), dtype=bool)
    for table in tables:
        t = np.asarray(table)[order]
        at = np.interp(slant_range, axis[order], t.real) + 1j * np.interp(slant_range, axis[order], t.imag)
        corrected |= at != 0
    return corrected
