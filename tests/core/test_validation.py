"""The shared validators of ``_core.validation``: their words are what users read."""

import numpy as np
import pytest

from microimpact._core.validation import check_choice, did_you_mean
from microimpact.io import Profile
from microimpact.surface import condition
from microimpact.surface.roughness import DETREND_METHODS


def test_a_none_choice_is_suggested_as_none_not_as_a_string():
    # detrend=None is the API's value; 'None' (a string) would be refused again
    with pytest.raises(ValueError) as err:
        check_choice("none", "detrend", DETREND_METHODS)
    assert "(did you mean None?)" in str(err.value)
    assert "'None'" not in str(err.value)


def test_the_public_path_suggests_the_value_the_api_takes():
    x = np.linspace(0.0, 1e-3, 101)
    profile = Profile(x=x, z=1e-7 * np.sin(x * 1e4))
    with pytest.raises(ValueError, match=r"did you mean None\?"):
        condition(profile, detrend="none")


def test_a_string_choice_keeps_its_quotes():
    assert did_you_mean("lin", ("line", "mean", None)) == " (did you mean 'line'?)"
    assert did_you_mean("zzz", ("line", "mean", None)) == ""
