"""The AGB error a requirement reads, with the error model it maps (``AGBError.error_model``)."""

from __future__ import annotations

import dataclasses


def agb_error_of(case):
    """The case's AGB error, which answers every question a requirement asks (``e2esim.retrieval.agb_variants``);
    one that names no error model (a plug-in retrieval's) maps the case's ``backscatter.error``."""
    agb = case["agb.error"]
    return agb if agb.error_model is not None else dataclasses.replace(agb, error_model=case["backscatter.error"])
