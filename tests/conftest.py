"""Shared fixtures."""

import matplotlib
import numpy as np
import pytest
from ids import ascii_id

matplotlib.use("Agg")


@pytest.fixture
def rng():
    """A seeded generator (scipy's convention)."""
    return np.random.default_rng(1234)


@pytest.fixture
def write_file(tmp_path):
    """``write_file(name, text)``: write `text` (UTF-8) to ``tmp_path / name``; the
    path."""

    def write(name, text):
        path = tmp_path / name
        path.write_text(text, encoding="utf-8")
        return path

    return write


def pytest_make_parametrize_id(config, val, argname):
    """Ids drawn from non-ASCII values in ASCII (tests/ids.py says why)."""
    if isinstance(val, str) and not val.isascii():
        return ascii_id(val)
    return None
