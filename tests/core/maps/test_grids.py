"""Tests of xface_core.maps.grids: integer-built grids and the paper's design axes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from xface_core.errors import XfaceValueError
from xface_core.maps.grids import (
    PAPER_H_OVER_D,
    PAPER_R_P,
    paper_h_over_d_exact,
    theta_grid,
    x0_grid,
)

SIZES = [3, 5, 41, 81, 401]


def magnitude_bits(a: np.ndarray) -> np.ndarray:
    """The bit patterns of |a| (so -0.0 and 0.0 compare equal, nothing else does)."""
    return np.abs(a).view(np.uint64)


@pytest.mark.parametrize("n", SIZES)
def test_x0_grid_is_mirror_symmetric_to_the_bit(n: int) -> None:
    x = x0_grid(n)
    assert (x[::-1] == -x).all()
    assert (magnitude_bits(x[::-1]) == magnitude_bits(x)).all()


def test_x0_grid_runs_from_minus_one_to_one_in_steps_of_one_twentieth() -> None:
    x = x0_grid()
    assert x.shape == (41,)
    assert x.dtype == np.float64
    assert (x[0], x[20], x[40]) == (-1.0, 0.0, 1.0)
    np.testing.assert_allclose(np.diff(x), 0.05, rtol=1e-12)
    # each node is one correctly rounded division of an exact integer
    assert [float(v) for v in x] == [i / 20 for i in range(-20, 21)]


@pytest.mark.parametrize("n", SIZES)
def test_symmetric_theta_grid_is_mirror_symmetric_to_the_bit(n: int) -> None:
    t = theta_grid(n, "symmetric")
    assert (t[::-1] == -t).all()
    assert (magnitude_bits(t[::-1]) == magnitude_bits(t)).all()


def test_symmetric_theta_grid_includes_both_ends_and_zero() -> None:
    t = theta_grid()
    assert (t[0], t[20], t[40]) == (-math.pi / 2, 0.0, math.pi / 2)
    np.testing.assert_allclose(np.diff(t), math.pi / 40, rtol=1e-12)


def test_paper_theta_grid_shifts_its_positive_half_by_half_a_step() -> None:
    t = theta_grid(kind="paper")
    assert t.shape == (41,)
    assert t[0] == -math.pi / 2
    assert t[20] == 0.0
    assert t[21] == math.pi / 80
    assert t[40] == pytest.approx(39 * math.pi / 80, rel=1e-15)
    steps = np.diff(t)
    np.testing.assert_allclose(steps[:20], math.pi / 40, rtol=1e-12)
    assert steps[20] == pytest.approx(math.pi / 80, rel=1e-12)
    np.testing.assert_allclose(steps[21:], math.pi / 40, rtol=1e-12)


def test_paper_theta_grid_is_not_mirror_symmetric() -> None:
    t = theta_grid(kind="paper")
    assert not np.isin(-t[21:], t).any()


@pytest.mark.parametrize("kind", ["symmetric", "paper"])
def test_theta_grids_are_strictly_increasing_within_half_pi(kind: str) -> None:
    t = theta_grid(81, kind)  # type: ignore[arg-type]
    assert (np.diff(t) > 0).all()
    assert t[0] >= -math.pi / 2
    assert t[-1] <= math.pi / 2


@pytest.mark.parametrize("bad", [0, 1, 2, 40, -41, 41.0, "41", True, None])
def test_grid_size_must_be_an_odd_integer_of_at_least_three(bad: object) -> None:
    with pytest.raises(XfaceValueError, match="odd integer"):
        x0_grid(bad)  # type: ignore[arg-type]
    with pytest.raises(XfaceValueError, match="odd integer"):
        theta_grid(bad)  # type: ignore[arg-type]


def test_numpy_integer_grid_size_is_accepted() -> None:
    assert x0_grid(np.int64(21)).shape == (21,)


def test_unknown_theta_grid_kind_is_rejected() -> None:
    with pytest.raises(XfaceValueError, match="kind"):
        theta_grid(41, "linspace")  # type: ignore[arg-type]


def test_paper_h_over_d_is_the_rounded_geometric_series_sixteen_to_the_i_minus_5_over_5() -> None:
    exact = paper_h_over_d_exact()
    assert len(PAPER_H_OVER_D) == 11
    np.testing.assert_allclose(exact[1:] / exact[:-1], 2.0**0.8, rtol=1e-12)
    assert [float(f"{v:.5g}") for v in exact] == list(PAPER_H_OVER_D)
    np.testing.assert_allclose(PAPER_H_OVER_D, exact, rtol=1e-4)


def test_paper_r_p_is_zero_to_ten() -> None:
    r_p = np.array(PAPER_R_P)
    assert r_p.tolist() == list(range(11))
    assert all(isinstance(v, float) for v in PAPER_R_P)
