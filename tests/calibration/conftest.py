"""Fixtures of the calibration tests (self-contained, so that this folder needs nothing from tests/conftest.py).

Statistical tests draw from ``rng``, seeded by ``E2ESIM_TEST_SEED`` (default 20210406, ``random`` for a
fresh seed), mixed with the test's id so that tests do not share streams; each accepts with |z| <= Z_ACCEPT.
"""

from __future__ import annotations

import os
import secrets
import zlib

import numpy as np
import pytest

_env = os.environ.get("E2ESIM_TEST_SEED", "20210406")
CAL_TEST_SEED = secrets.randbelow(2**31) if _env == "random" else int(_env)


@pytest.fixture
def rng(request) -> np.random.Generator:
    key = zlib.crc32(request.node.nodeid.encode())
    return np.random.default_rng([CAL_TEST_SEED, key])
