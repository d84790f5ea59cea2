"""Error budget of the backscattering coefficient: speckle and noise, temporal variability, calibration and
area projection (Ahmed, Siqueira & Hensley 2014, Section II-D, eqs. 20-38), vectorised over cases."""
