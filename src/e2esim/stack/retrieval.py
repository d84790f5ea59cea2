"""The power law of a multi-pass estimate (kind ``retrieval``): the exponent of the ground-cancelled channel, and the
uncertainty of that exponent as the AGB error's model term.

The project found no published exponent of the ground-cancelled HV power law, so a
ground-cancelled estimate takes either the HV exponent of the biome (``same``: conservative) or the exponent the
random-volume-over-ground split of the scene implies, p / (1 + mu_hv) (``rvog``: a stated model,
``e2esim.stack.sites.ground_cancelled_exponent``, ground-cancellation.md eq. 19). Single-date and multi-date
estimates keep the biome's exponent (Men et al. 2021, eq. 15). The exponent is uncertain: by default
(``model_uncertainty.mode: stated``) its published spread (``e2esim.retrieval.model_error``) is propagated as the
``model`` contribution (docs/theory/retrieval.md, eqs. 7.1-7.2).
"""

from __future__ import annotations

from e2esim.module import fail
from e2esim.params import Param
from e2esim.retrieval import model_error
from e2esim.retrieval.modules import PowerLawRetrieval
from e2esim.stack.sites import ground_cancelled_exponent

GROUND_CANCELLED_EXPONENTS = ("rvog", "same")


class StackPowerLawRetrieval(PowerLawRetrieval):
    """AGB = A sigma^p for single-date, multi-date and ground-cancelled HV, with the model-error term of its
    exponent's uncertainty (module docstring)."""

    type_name = "stack_power_law"
    summary = ("power law for multi-pass HV estimates: the biome's exponent, or for ground-cancelled HV "
               "p / (1 + mu_hv) from the scene's RVoG split (a stated model); its uncertainty as the model term")
    params = PowerLawRetrieval.params + (
        Param("ground_cancelled_exponent", "str", "exponent of a ground-cancelled estimate when exponent is null: "
              "rvog (p / (1 + mu_hv)) or same (the biome's)", default="rvog", choices=GROUND_CANCELLED_EXPONENTS),
        model_error.model_uncertainty_group("stated", 1),
    )
    uses = ("backscatter.budget", "scene.stack")  # the budget: read by combine (the random-error terms)

    def case_exponent(self, case) -> float:
        p = self.exponent_for(case["scene.covariance"])
        model = case["backscatter.error"]
        cancelled = getattr(getattr(model, "combination", None), "kind", None) == "ground_cancelled"
        if self.si["exponent"] is None and cancelled and self.si["ground_cancelled_exponent"] == "rvog":
            return ground_cancelled_exponent(p, case["scene.stack"].forest.ground_to_volume_db[1])
        return p

    def model_term(self, case, exponent):
        """The uncertainty of the exponent p (and of the coefficient) as an equivalent relative sigma error
        (``model_error.sigma_contribution``, eqs. 7.1-7.2 with c = p, alpha = 1/p), or None (mode none)."""
        scene = case["scene.covariance"]
        try:
            term = model_error.case_model_variance(self.si["model_uncertainty"], 1.0 / exponent, exponent,
                                                   self.case_agb(case), scene.biome, channels=("hv",))
        except KeyError:
            raise fail(self, f"case {case.index}: no reference AGB for the scene's biome {scene.biome!r}",
                       "give model_uncertainty.reference_agb_t_ha", key="model_uncertainty") from None
        return None if term is None else model_error.sigma_contribution(term[0], exponent)
