"""Which error model a requirement reads: the one the case's AGB error maps (``AGBError.error_model``)."""

from __future__ import annotations


def error_model_of(case):
    """The single-channel error model the case's AGB error maps: the one the retrieval names (a channel or a
    channel combination of a multi-channel model), else ``backscatter.error``."""
    model = getattr(case["agb.error"], "error_model", None)
    return model if model is not None else case["backscatter.error"]
