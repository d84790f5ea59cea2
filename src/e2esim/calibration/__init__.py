"""Calibration: estimators of Faraday rotation, crosstalk, channel imbalance and gain on simulated data,
and the calibration modules that turn the raw system errors into what correction leaves.

Quegan et al. (2018), Sections 3-5 (seed 003): the Faraday-rotation estimators it uses live with the rest of
the Faraday-rotation domain (``e2esim.faraday.estimators``, ``theory``, ``chirp``); here are the
distributed-target algorithm of Quegan (1994) (``quegan1994``), system errors
from polarimetric calibrators by non-linear least squares (``transponder``), radiometric calibration
(``radiometric``), and the residual errors a calibration strategy leaves (``pipeline``, ``modules``).
Calibration data are simulated through the project's one system model
(``e2esim.polarimetry.system_model``, ``e2esim.polarimetry.simulate``) and ``targets``.
"""
