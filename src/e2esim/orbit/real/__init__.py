"""Real orbits: state vectors from files (EO CFI, NISAR) and two-line element sets (SGP4), in Earth-fixed axes.

``trajectory.Trajectory`` is what every reader returns; ``site_passes`` finds the zero-Doppler acquisitions of a
site on it; ``e2esim.orbit.real_modules`` makes them the ``AcquisitionGeometry`` of a scenario. docs/orbits.md.
"""
