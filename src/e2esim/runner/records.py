"""Flatten the products of one case into named scalars for summary.json, results.h5 and reports.

Every product type that has outputs writes its own scalars (``scalars()``); the product's declaration
(``e2esim.products``) gives the prefix of their names. Names are dotted, units in the name or stated in
docs/output-format.md (sigma errors in m^2/m^2, AGB errors in percent, levels in dB, angles in degrees). A
product that is the very object of an earlier one (the residual Faraday rotation when nothing corrected it)
is not written twice.
"""

from __future__ import annotations

import numpy as np

from e2esim import products as P

DECLARATIONS = {p.name: p for p in P.BUILT_IN}


def case_scalars(products, declarations: dict | None = None) -> dict:
    """``{name: float}`` of every product with outputs, in the order the stages made them."""
    declared = dict(DECLARATIONS, **(declarations or {}))
    out: dict = {}
    written: list = []
    for name, value in products.items():
        product = declared.get(name)
        if product is None or product.scalars is None or any(value is w for w in written):
            continue
        written.append(value)
        prefix = f"{product.scalars}." if product.scalars else ""
        out.update({prefix + key: v for key, v in value.scalars().items()})
    return {k: float(np.real(v)) for k, v in out.items()}
