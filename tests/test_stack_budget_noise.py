"""The noise of the stack error budget (issue 21, item 11): each channel's combined estimate has the noise power
sigma_n tr Q for HH and VV and sigma_n tr Q / 2 for the symmetrised HV = (M_hv + M_vh) / 2, which averages two
independent noise draws of power sigma_n (Men et al. 2021, eq. 3). The budget used sigma_n tr Q for HV too."""

import numpy as np
import pytest

from e2esim.polarimetry.system_model import RECIPROCAL_CHANNELS
from e2esim.settings import SimulationSettings
from e2esim.stack.images import ground_cancel, measured_stack_images
from e2esim.stack.modules import RVoGStackScene, StackBackscatterError, StackErrorBudget
from e2esim.testing import reference_case
from helpers import Z_ACCEPT


def _budget_case(estimator):
    settings = SimulationSettings(mode="analytic", seed=1, looks=2000)
    case = reference_case(("scene.covariance", "system.residual", "faraday.residual", "instrument"),
                          settings=settings)
    case = case.adding({"scene.stack": RVoGStackScene(site="tropical").forward(case)["scene.stack"]})
    case = case.adding(StackBackscatterError(channels="all", estimator=estimator).forward(case))
    return case.adding(StackErrorBudget().forward(case))


def _budget_noise(case) -> np.ndarray:
    """The noise power (m^2/m^2) of each channel's combined estimate that the budget uses: sigma / SNR (eq. 26)."""
    budget = case["backscatter.budget"]
    return np.asarray(budget.sigma) / np.asarray(budget.snr)


@pytest.mark.parametrize("estimator", ["single_date", "multi_date", "ground_cancelled"])
def test_the_stack_budget_halves_the_noise_of_the_symmetrised_hv(estimator):
    case = _budget_case(estimator)
    model, budget = case["backscatter.error"], case["backscatter.budget"]
    nesz = 10 ** (case["instrument"].nesz_db / 10)
    trq = model.combination.noise_gain
    assert budget.channels == ("hh", "hv", "vv")
    np.testing.assert_allclose(_budget_noise(case), nesz * trq * np.array([1.0, 0.5, 1.0]), rtol=1e-12)
    # the thermal term of eq. (21) of Ahmed et al. (2014) with it: 1 / (sqrt(N N_ot) SNR)
    hv = budget.channel("hv")
    expected = 1 / np.sqrt(hv.looks * hv.observations) * (nesz * trq / 2) / hv.sigma
    np.testing.assert_allclose(hv.relative_sd["thermal_noise"], expected, rtol=1e-12)
    # the error model's noise bias of each channel (ground-cancellation.md, "Reduction") is the same noise
    np.testing.assert_allclose(model.current_joint().bias_noise, _budget_noise(case), rtol=1e-12)


def test_the_budget_noise_is_the_noise_of_the_simulated_images(rng):
    """Brute force: noise-only quad-pol images of every pass (each measured channel with its own noise of power
    sigma_n, no system error), the per-pass estimates (hh, (hv + vh)/2, vv) and the ground-cancelled combination
    of the measured images (e2esim.stack.images, which never uses the noise factors): the mean combined power of
    each channel is the budget's noise, within Z_ACCEPT standard errors."""
    case = _budget_case("ground_cancelled")
    combination = case["backscatter.error"].combination
    nesz = 10 ** (case["instrument"].nesz_db / 10)
    n, pixels = combination.passes, 200_000
    images = measured_stack_images(np.zeros((pixels, n, 3), complex), np.zeros((n, 4), complex),
                                   np.ones((n, 2), complex), np.zeros(n), np.ones(n), nesz, rng)
    combos = np.einsum("rn,knc->rkc", combination.weights, images)
    power = np.einsum("r,rkc->kc", combination.coefficients, np.abs(combos) ** 2)  # per pixel and channel
    np.testing.assert_allclose(np.real(np.diag(ground_cancel(images, combination))), power.mean(axis=0), rtol=1e-10)
    z = (power.mean(axis=0) - _budget_noise(case)) / (power.std(axis=0, ddof=1) / np.sqrt(pixels))
    assert RECIPROCAL_CHANNELS == ("hh", "hv", "vv")
    assert np.all(np.abs(z) < Z_ACCEPT), z
