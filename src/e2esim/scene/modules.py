"""Scene modules (kind ``scene``): the scattering covariance a case looks at."""

from __future__ import annotations

import numpy as np

from e2esim import products as P
from e2esim.module import Stage
from e2esim.params import Param
from e2esim.scene.agb_model import forest_covariance
from e2esim.scene.biome_power_laws import BIOME_EXPONENTS
from e2esim.scene.covariance import ScatteringCovariance
from e2esim.scene.table1 import TABLE1_FORESTS


class _FixedScene(Stage):
    """A scene whose parameters fix its covariance: ``setup`` makes it (``covariance``), every case looks at it."""

    kind = "scene"
    provides = (P.SCENE,)

    def forward(self, case):
        return {"scene.covariance": self.covariance}


class Table1ForestScene(_FixedScene):
    """One of the five forests of Men et al. (2021), Table I."""

    type_name = "table1_forest"
    summary = "P-band forest covariance from Men et al. (2021), Table I (boreal 50/200/350, tropical 338/341 t/ha)"
    params = (
        Param("forest", "str", "Table I forest", default="boreal_200", choices=tuple(TABLE1_FORESTS)),
    )

    def setup(self):
        biome, agb, hh, hv, vv, r, theta = TABLE1_FORESTS[self.si["forest"]]
        self.covariance = ScatteringCovariance.from_powers(
            hh, hv, vv, r, np.radians(theta), agb_t_ha=agb, biome=biome,
            label=f"{biome} {agb:g} t/ha (Men et al. 2021, Table I)",
        )


class ForestAGBScene(_FixedScene):
    """Covariance that varies continuously with AGB (e2esim.scene.agb_model), for sweeps over AGB."""

    type_name = "forest_agb_model"
    summary = "forest covariance continuous in AGB: power-law sigma_hv, co-pol terms interpolated from Table I"
    params = (
        Param("biome", "str", "forest biome", default="boreal", choices=tuple(BIOME_EXPONENTS)),
        Param("agb_t_ha", "float", "above-ground biomass", default=200.0, unit="t/ha",
              exclusive_minimum=0.0, maximum=1000.0),
        Param("exponent", "float", "power-law exponent p of sigma_hv(AGB); null: the biome's (2.2, 1.9)",
              default=None, exclusive_minimum=0.0, nullable=True),
    )

    def setup(self):
        c = self.si
        self.covariance = forest_covariance(c["biome"], c["agb_t_ha"], c["exponent"])


class CovarianceScene(_FixedScene):
    """A user-given reciprocal covariance in the basis (hh, hv, vv), in backscattering-coefficient units.

    Reflection symmetry (zero HH-HV and HV-VV correlation) is the default; non-zero values are accepted
    and handled by the Monte Carlo, while the analytic error model refuses them.
    """

    type_name = "covariance"
    summary = "user-given 3x3 covariance (hh, hv, vv): powers and complex correlations, checked Hermitian PSD"
    params = (
        Param("sigma_hh", "float", "HH backscattering coefficient", unit="m2/m2", exclusive_minimum=0.0,
              default=0.649),
        Param("sigma_hv", "float", "HV backscattering coefficient", unit="m2/m2", exclusive_minimum=0.0,
              default=0.0726),
        Param("sigma_vv", "float", "VV backscattering coefficient", unit="m2/m2", exclusive_minimum=0.0,
              default=0.274),
        Param("hhvv_magnitude", "float", "R = |<S_hh S_vv*>|", unit="m2/m2", minimum=0.0, default=0.150),
        Param("hhvv_phase_deg", "float", "phase of <S_hh S_vv*>", unit="deg", minimum=-180.0, maximum=180.0,
              default=-96.8),
        Param("hhhv_magnitude", "float", "|<S_hh S_hv*>| (0 under reflection symmetry)", unit="m2/m2",
              minimum=0.0, default=0.0),
        Param("hhhv_phase_deg", "float", "phase of <S_hh S_hv*>", unit="deg", minimum=-180.0, maximum=180.0,
              default=0.0),
        Param("hvvv_magnitude", "float", "|<S_hv S_vv*>| (0 under reflection symmetry)", unit="m2/m2",
              minimum=0.0, default=0.0),
        Param("hvvv_phase_deg", "float", "phase of <S_hv S_vv*>", unit="deg", minimum=-180.0, maximum=180.0,
              default=0.0),
        Param("agb_t_ha", "float", "AGB the covariance represents (for reports)", unit="t/ha",
              exclusive_minimum=0.0, default=None, nullable=True),
        Param("biome", "str", "biome label (sets the default power-law exponent: boreal, tropical)",
              default=None, nullable=True),
    )

    def setup(self):
        c = self.si
        hhvv = c["hhvv_magnitude"] * np.exp(1j * c["hhvv_phase_rad"])
        hhhv = c["hhhv_magnitude"] * np.exp(1j * c["hhhv_phase_rad"])
        hvvv = c["hvvv_magnitude"] * np.exp(1j * c["hvvv_phase_rad"])
        m = np.array(
            [
                [c["sigma_hh"], hhhv, hhvv],
                [np.conj(hhhv), c["sigma_hv"], hvvv],
                [np.conj(hhvv), np.conj(hvvv), c["sigma_vv"]],
            ],
            dtype=complex,
        )
        self.covariance = ScatteringCovariance(m, agb_t_ha=c["agb_t_ha"], biome=c["biome"], label="user covariance")
