"""Ionospheric scintillation of a P-band SAR: the power-law phase screen (``screen``), its climatology
(``climatology``), the geometry of the synthetic aperture through it (``aperture``), the azimuth impulse response
by Monte Carlo (``irf``) and by the weak-scatter theory (``irf_analytic``), and the radiometric consequences
(``consequences``) that the error terms of ``e2esim.scintillation.modules`` add to the error model.
docs/theory/scintillation.md derives every equation."""
