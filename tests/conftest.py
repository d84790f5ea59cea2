"""Shared fixtures.

Statistical tests draw from ``rng``, seeded by ``E2ESIM_TEST_SEED`` (default 20210406). Set it to
another integer, or to ``random``, to check that a test is not tuned to one seed (the model is
scikit-learn's ``global_random_seed``); the seed in use is printed in the test report header.
"""

from __future__ import annotations

import os
import secrets

import numpy as np
import pytest

_env = os.environ.get("E2ESIM_TEST_SEED", "20210406")
TEST_SEED = secrets.randbelow(2**31) if _env == "random" else int(_env)


def pytest_report_header(config):
    return f"e2esim test seed: {TEST_SEED} (set E2ESIM_TEST_SEED=<int> or random)"


@pytest.fixture
def seed(request) -> int:
    """A seed that depends on E2ESIM_TEST_SEED and on the test, so tests do not share streams."""
    return int(np.random.SeedSequence([TEST_SEED, abs(hash(request.node.nodeid)) % 2**31]).generate_state(1)[0])


@pytest.fixture
def rng(seed) -> np.random.Generator:
    return np.random.default_rng(seed)


def z_score(estimate, expected, standard_error):
    """Standardised difference; statistical tests accept |z| <= Z_ACCEPT."""
    return (np.asarray(estimate) - np.asarray(expected)) / np.asarray(standard_error)


Z_ACCEPT = 4.5
"""Acceptance for single statistical comparisons: two-sided false-failure probability 7e-6 per
comparison, so a suite of a few hundred comparisons fails by chance about once in 500 runs."""
