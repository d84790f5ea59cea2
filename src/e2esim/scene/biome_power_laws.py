"""How sigma_hv grows with AGB in each forest biome of the scene: ``sigma_hv ∝ AGB^(1/p)``, Men et al. (2021),
eq. (15), with the exponents p of Schlund et al. (2018) as quoted in Men et al. (2021), Section III-D.

These are the truth's: the scene's AGB model (``agb_model``) builds its forests with them. A retrieval that is
not given its own exponent assumes the scene's (``e2esim.retrieval.power_law.BIOME_EXPONENTS`` is this table),
so a misspecified estimator is a retrieval setting, never a change of the scene.
"""

BIOME_EXPONENTS = {"boreal": 2.2, "tropical": 1.9}
"""Power-law exponent p by biome, Men et al. (2021), Section III-D and Table III."""
