"""The one rule behind integer arguments (xface_core.errors.is_integer_in)."""

from __future__ import annotations

import numpy as np
import pytest

from xface_core.errors import XfaceValueError, is_integer_in
from xface_core.study.noise import PoseNoise


@pytest.mark.parametrize("value", [1, 7, np.int64(3), np.uint8(5)])
def test_an_integer_in_range_passes(value: object) -> None:
    assert is_integer_in(value, 1, 10)


@pytest.mark.parametrize("value", [True, False, 3.0, "3", None, np.float64(3.0)])
def test_what_is_not_an_integer_fails(value: object) -> None:
    assert not is_integer_in(value, 0, 10)


@pytest.mark.parametrize(("value", "lo", "hi"), [(0, 1, 10), (11, 1, 10), (-1, 0, np.inf)])
def test_an_integer_out_of_range_fails(value: int, lo: int, hi: float) -> None:
    assert not is_integer_in(value, lo, hi)


def test_without_an_upper_bound_any_large_integer_passes() -> None:
    assert is_integer_in(2**70, 1)


def test_a_bool_seed_is_refused_for_the_noise() -> None:
    # It used to pass as 1: bool is an int subclass.
    with pytest.raises(XfaceValueError, match="seed"):
        PoseNoise(0.1, 0.1, samples=8, seed=True)
