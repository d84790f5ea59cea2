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
