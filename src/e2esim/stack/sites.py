"""Forest-structure presets of the multi-pass scene, for the tropical and boreal sites.

The single-pass powers are those of Men et al. (2021), Table I (``e2esim.scene.table1``); these presets add what
the random-volume-over-ground model needs. The project found no published P-band values of extinction and
ground-to-volume ratios for TropiSAR or BioSAR, so every number below but the cited ones is **assumed** and
marked so; the scenarios vary them.

* tropical (Paracou, French Guiana, TropiSAR; Table I tropical 338 t/ha): h_v = 35 m. The layer at 30 +- 10 m
  above the ground correlates best with AGB at Paracou (Ho Tong Minh et al. 2014, IEEE TGRS 52(2) 967-979,
  abstract), and French Guiana canopies reach beyond 35 m (canopy-height mapping of French Guiana, Frontiers in
  Remote Sensing 2024, doi:10.3389/frsen.2024.1484900, abstract); 35 m itself is assumed.
* boreal (central Siberia in the scenarios; Table I boreal 200 t/ha from Quegan & Lomas 2015): h_v = 20 m,
  assumed.
* both: extinction 0.15 dB/m (assumed), volume HH-VV coherence 1/3 (randomly oriented thin dipoles, Freeman &
  Durden 1998, IEEE TGRS 36(3)); ground-to-volume ratios (hh, hv, vv) of (-3, -10, -6) dB tropical and (+3, -3, 0)
  dB boreal (assumed; the ordering HH > VV > HV of the ground term follows the ground-trunk double bounce, which
  has no HV part and a larger HH than VV Fresnel product, Freeman & Durden 1998; the BIOMASS processor searches
  -20 to +20 dB: BPS, github.com/BioPAL/BPS, ``xsd/biomass-xsd/bio-aux-pp2_2a.xsd``, ``groundToVolumeRatioRange``).
"""

from __future__ import annotations

from e2esim.stack.rvog import ForestStructure

SITES = {
    "tropical": ForestStructure(35.0, 0.15, (-3.0, -10.0, -6.0), 1.0 / 3.0,
                                "tropical (Paracou): h_v 35 m; extinction and ground-to-volume ratios assumed"),
    "boreal": ForestStructure(20.0, 0.15, (3.0, -3.0, 0.0), 1.0 / 3.0,
                              "boreal: h_v 20 m, extinction and ground-to-volume ratios assumed"),
}
"""Forest structures of the sites (module docstring)."""

SITE_FORESTS = {"tropical": "tropical_338", "boreal": "boreal_200"}
"""The Table I forest of each site."""


def ground_cancelled_exponent(exponent: float, ground_to_volume_db: float) -> float:
    """Power-law exponent p of the ground-cancelled HV channel implied by the RVoG split (ground-cancellation.md,
    eq. 19), **a stated model, not a published value**: if the HV ground term does not change with AGB and the
    volume term carries all of the AGB dependence, sigma_hv = sigma_g + sigma_v(W) has d ln sigma_hv / d ln W =
    (sigma_v / sigma_hv) d ln sigma_v / d ln W, while the ground-cancelled power follows the volume alone, so
    p_GC = p_HV / (1 + mu_hv). Mariotti d'Alessandro et al. (2020, abstract) find ground-cancelled HV more
    sensitive to AGB than the single images, which this reproduces qualitatively."""
    return exponent / (1.0 + 10.0 ** (ground_to_volume_db / 10.0))
