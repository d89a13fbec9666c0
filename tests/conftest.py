"""Shared fixtures."""

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")


@pytest.fixture
def rng():
    """A seeded generator (scipy's convention)."""
    return np.random.default_rng(1234)
