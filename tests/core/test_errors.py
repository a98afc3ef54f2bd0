"""The one rule behind integer arguments (xface_core.errors.is_integer_in) and the one behind
real arguments (real_number, is_positive_up_to)."""

from __future__ import annotations

import numpy as np
import pytest

from xface_core.errors import XfaceValueError, is_integer_in, is_positive_up_to, real_number
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


@pytest.mark.parametrize("value", [2, 2.5, np.float64(2.5), np.int64(2)])
def test_a_real_number_is_read_as_a_float(value: object) -> None:
    number = real_number(value)
    assert isinstance(number, float)
    assert number == float(value)  # type: ignore[arg-type]


@pytest.mark.parametrize("value", [True, False, "2", None, [2.0], complex(2, 0)])
def test_what_is_not_a_real_number_is_none(value: object) -> None:
    assert real_number(value) is None


@pytest.mark.parametrize("value", [1e-300, 0.5, 1, 1.0])
def test_a_positive_number_up_to_the_bound_passes(value: object) -> None:
    assert is_positive_up_to(value, 1.0)


@pytest.mark.parametrize("value", [0, 0.0, -1.0, 1.0000001, float("nan"), float("inf"), True])
def test_zero_past_the_bound_nan_and_bools_fail_the_positive_check(value: object) -> None:
    assert not is_positive_up_to(value, 1.0)
