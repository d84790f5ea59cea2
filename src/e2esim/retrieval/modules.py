"""Retrieval modules (kind ``retrieval``): from the sigma_hv error to the relative AGB error."""

from __future__ import annotations

import numpy as np

from e2esim.errors import ConfigError
from e2esim.module import Module
from e2esim.params import Param
from e2esim.retrieval.agb_error import AGBError
from e2esim.retrieval.power_law import BIOME_EXPONENTS


class PowerLawRetrieval(Module):
    """AGB = A sigma_hv^p (Men et al. 2021, eq. 15); relative errors through eq. (16)."""

    kind = "retrieval"
    type_name = "power_law"
    summary = "power law AGB = A sigma_hv^p (Men et al. 2021, eq. 15); p = 2.2 boreal, 1.9 tropical"
    params = (
        Param("exponent", "float", "power-law exponent p (null: from the scene's biome, 2.2 boreal, 1.9 tropical)",
              default=None, exclusive_minimum=0.0, maximum=10.0, nullable=True),
    )
    requires = ("scene", "backscatter")
    provides = ("agb",)

    def exponent_for(self, scene) -> float:
        if self.config["exponent"] is not None:
            return self.config["exponent"]
        if scene.biome not in BIOME_EXPONENTS:
            raise ConfigError(
                self.location.child("exponent"),
                f"null needs a scene with a known biome, but the scene's biome is {scene.biome!r}",
                f"give a number, or a scene of biome {' or '.join(BIOME_EXPONENTS)}",
            )
        return BIOME_EXPONENTS[scene.biome]

    def forward(self, state):
        bs = state.backscatter
        p = self.exponent_for(state.scene)
        relative = None
        if bs.montecarlo is not None:
            ref = np.asarray(bs.montecarlo.reference["hv"])
            errors = bs.montecarlo.hv
            relative = errors / (ref[:, None] if ref.ndim else ref)
        agb = AGBError.from_sigma_errors(
            p,
            bs.sigma_hv,
            None if bs.analytic is None else float(bs.analytic.mean),
            None if bs.analytic is None else float(bs.analytic.sd),
            relative,
        )
        return state.with_(agb=agb)
