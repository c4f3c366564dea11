"""Shared fixtures: reference models are loaded once per session from the repository's
``generated/`` (built there when missing)."""

import numpy as np
import pytest

import gpmegen


@pytest.fixture(scope="session")
def rigid():
    return gpmegen.load(nrfe=1, backend="numpy")


@pytest.fixture(scope="session")
def flexible():
    return gpmegen.load(nrfe=5, backend="numpy")


@pytest.fixture
def rng():
    return np.random.default_rng(20261122)
