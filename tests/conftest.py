"""Shared fixtures."""

import matplotlib
import numpy as np
import pytest

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
    """Test ids in ASCII ('µm' -> 'u?m'-like 'µ' replaced): tools that hand
    listed ids back to pytest (mutmut, benchmarks/mutation_score.py) do not
    round-trip pytest's escaped non-ASCII ids."""
    if isinstance(val, str) and not val.isascii():
        return val.encode("ascii", "replace").decode()
    return None
