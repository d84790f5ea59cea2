"""The power law of a multi-pass estimate (kind ``retrieval``): the exponent of the ground-cancelled channel.

The project found no published exponent of the ground-cancelled HV power law, so a
ground-cancelled estimate takes either the HV exponent of the biome (``same``: conservative) or the exponent the
random-volume-over-ground split of the scene implies, p / (1 + mu_hv) (``rvog``: a stated model,
``e2esim.stack.sites.ground_cancelled_exponent``, ground-cancellation.md eq. 19). Single-date and multi-date
estimates keep the biome's exponent (Men et al. 2021, eq. 15).
"""

from __future__ import annotations

from e2esim.params import Param
from e2esim.retrieval.modules import PowerLawRetrieval
from e2esim.stack.sites import ground_cancelled_exponent

GROUND_CANCELLED_EXPONENTS = ("rvog", "same")


class StackPowerLawRetrieval(PowerLawRetrieval):
    """AGB = A sigma^p for single-date, multi-date and ground-cancelled HV (module docstring)."""

    type_name = "stack_power_law"
    summary = ("power law for multi-pass HV estimates: the biome's exponent, or for ground-cancelled HV "
               "p / (1 + mu_hv) from the scene's RVoG split (a stated model)")
    params = PowerLawRetrieval.params + (
        Param("ground_cancelled_exponent", "str", "exponent of a ground-cancelled estimate when exponent is null: "
              "rvog (p / (1 + mu_hv)) or same (the biome's)", default="rvog", choices=GROUND_CANCELLED_EXPONENTS),
    )
    uses = ("scene.stack",)

    def case_exponent(self, case) -> float:
        p = self.exponent_for(case["scene.covariance"])
        model = case["backscatter.error"]
        cancelled = getattr(getattr(model, "combination", None), "kind", None) == "ground_cancelled"
        if self.si["exponent"] is None and cancelled and self.si["ground_cancelled_exponent"] == "rvog":
            return ground_cancelled_exponent(p, case["scene.stack"].forest.ground_to_volume_db[1])
        return p
