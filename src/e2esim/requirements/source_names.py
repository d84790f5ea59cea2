"""Words for the error sources of the chain, as the verdicts' coverage, summary.json and the report name them."""

from __future__ import annotations

SOURCE_NAMES = {
    "crosstalk": "crosstalk", "channel_imbalance": "channel imbalance", "noise": "noise",
    "faraday_rotation": "Faraday rotation", "gain": "gain error", "speckle_noise": "speckle and noise",
    "temporal": "temporal variability", "calibration": "radiometric calibration",
    "area_projection": "area projection", "regression": "regression (retrieval model)",
    "model": "model (retrieval exponents and coefficients)",
    "system_distortions": "system distortions", "noise_bias": "noise bias",
    "faraday_difference": "Faraday-rotation difference", "system_instability": "system instability",
    "temporal_decorrelation": "temporal decorrelation",
    "assumed_random": "random terms (assumed)", "assumed_retrieval": "retrieval model (assumed)",
}
"""Words for the source names of the built-in models; another source is shown by its name."""


def source_name(source: str) -> str:
    return SOURCE_NAMES.get(source, source.replace("_", " "))


COUPLINGS = {
    "faraday_rotation": "Faraday rotation acts on the backscatter only through crosstalk and channel imbalance (the "
                        "system model M = A R F S F T: Men et al. 2021, eqs. 11-12), so its effect and theirs do not "
                        "add",
    "system_instability": "system instability is not an error of its own: it sets how the passes' crosstalk, "
                          "channel-imbalance and gain errors average over the stack",
    "temporal_decorrelation": "temporal decorrelation changes the scene the other errors act on",
    "channel_imbalance": "crosstalk and channel imbalance enter the second-order terms of the error as products",
}
"""Why the sources of the built-in error models couple (their effects on the mean and variance of the sigma error do
not add): the words for the remainder of a budget, ``share.interactions_<unit>``, naming the coupling sources a
verdict's budget holds."""


def coupling_words(sources) -> str:
    """Why the named sources' effects do not add, for those of them in ``COUPLINGS``; a general phrase otherwise."""
    said = [COUPLINGS[s] for s in sources if s in COUPLINGS]
    return "; ".join(said) if said else "the error model's sources do not act independently of one another"
