"""integrate.py: one Dormand-Prince step against the closed-form path, the projection."""

from __future__ import annotations

import numpy as np
import pytest

from xface_core._engine.integrate import dense_angles, project, rk_step
from xface_core._engine.motion import velocity
from xface_core._engine.pairs import pair_at
from xface_core.physics import DEFAULT_SETTINGS


def _dense_step(incline, h: float) -> tuple[float, float, np.ndarray]:
    """One projected step down the incline, its end angles and its dense output."""
    seg = incline.segment()
    k1b, k1m, _, _ = velocity(seg.held, 0.0, incline.phi_m0, incline.y0)
    nb, nm, _, _, ok = rk_step(seg, incline.step(h), k1b, k1m)
    assert ok
    return nb, nm, seg.dense


def _step(incline, h: float, *, projected: bool = True) -> tuple[float, float, float, float, bool]:
    """One step down the held incline from its exact start. Without ``projected`` the
    projection is given no metric to move in (W^-1 = 0), leaving the bare Dormand-Prince
    step; the rate itself uses the held base's W^-1 = diag(0, 1) either way."""
    seg = incline.segment()
    seg = seg._replace(held=seg.held._replace(winv_m=1.0 if projected else 0.0))
    k1b, k1m, _, _ = velocity(seg.held, 0.0, incline.phi_m0, incline.y0)
    return rk_step(seg, incline.step(h), k1b, k1m)


def test_a_step_lands_on_the_closed_form_path(incline) -> None:
    h = 0.02
    nb, nm, _, em, ok = _step(incline, h)
    assert ok
    assert nb == 0.0
    assert nm == pytest.approx(incline.phi_m_at(h), abs=1e-14)
    # ... and would be accepted at the default tolerances.
    assert em <= DEFAULT_SETTINGS.atol + DEFAULT_SETTINGS.rtol * abs(nm)


@pytest.mark.parametrize("h", [0.05, 0.02, 0.01])
def test_the_bare_step_lies_within_its_error_estimate(incline, h: float) -> None:
    _, nm, _, em, ok = _step(incline, h, projected=False)
    assert ok
    assert 0.0 < abs(nm - incline.phi_m_at(h)) <= em


def test_the_error_estimate_is_of_fifth_order(incline) -> None:
    # The embedded 4th-order solution's local error, and so the estimate, scales as h^5.
    ratio = _step(incline, 0.02)[3] / _step(incline, 0.01)[3]
    assert 2**5 * 0.75 < ratio < 2**5 * 1.25


def test_projection_brings_one_contact_back_along_the_metric(incline) -> None:
    # Base free with W^-1 = diag(1/4, 1): the correction runs along W^-1 a.
    pb, pm, ym = 0.0, incline.phi_m0 + 1e-3, incline.y0
    assert abs(incline.gap(0, pm, ym, pb)) > 1e-4
    qb, qm = project(incline.segment(winv_b=0.25).held, pb, pm, ym)
    assert abs(incline.gap(0, qm, ym, qb)) <= 2e-15
    _, _, a_b, a_m, *_ = pair_at(incline.table, 0, pb, pm, incline.x0, ym)
    along = np.array([0.25 * a_b, a_m])
    moved = np.array([qb - pb, qm - pm])
    assert abs(along[0] * moved[1] - along[1] * moved[0]) <= 1e-6 * np.linalg.norm(moved)


def test_projection_brings_two_contacts_back(incline) -> None:
    # At the descent s_touch both pairs of the incline touch; start off both.
    ym = incline.y0 - incline.s_touch
    pb, pm = 2e-3, incline.phi_m_at(incline.s_touch) - 1e-3
    assert min(abs(incline.gap(0, pm, ym, pb)), abs(incline.gap(1, pm, ym, pb))) > 1e-4
    qb, qm = project(incline.segment(n_active=2, winv_b=1.0).held, pb, pm, ym)
    assert abs(incline.gap(0, qm, ym, qb)) <= 2e-15
    assert abs(incline.gap(1, qm, ym, qb)) <= 2e-15


def test_projection_of_a_held_base_leaves_it_alone(incline) -> None:
    qb, qm = project(incline.segment().held, 0.0, incline.phi_m0 - 1e-3, incline.y0)
    assert qb == 0.0
    assert qm == pytest.approx(incline.phi_m0, abs=1e-15)


def test_the_dense_output_starts_and_ends_on_the_step(incline) -> None:
    h = 0.02
    nb, nm, dense = _dense_step(incline, h)
    assert tuple(dense[0, :5]) == (0.0, incline.phi_m0, incline.y0, h, 1.0)
    assert dense_angles(dense, 0, 0.0) == (0.0, incline.phi_m0)
    end_b, end_m = dense_angles(dense, 0, h)
    assert end_b == nb
    assert end_m == pytest.approx(nm, abs=1e-15)


@pytest.mark.parametrize("fraction", [0.1, 0.25, 0.5, 0.75, 0.9])
def test_the_dense_output_follows_the_closed_form_path_inside_the_step(
    incline, fraction: float
) -> None:
    # Order 4 inside the step: at the default tolerances' step size it stays within the
    # step's own error of the exact path.
    h = 0.02
    _, _, dense = _dense_step(incline, h)
    _, pm = dense_angles(dense, 0, fraction * h)
    assert pm == pytest.approx(incline.phi_m_at(fraction * h), abs=1e-9)


def test_the_dense_output_error_falls_with_the_fourth_power_of_the_step(incline) -> None:
    def error(h: float) -> float:
        _, _, dense = _dense_step(incline, h)
        return abs(dense_angles(dense, 0, 0.5 * h)[1] - incline.phi_m_at(0.5 * h))

    ratio = error(0.04) / error(0.02)
    assert 2**4 * 0.5 < ratio < 2**6 * 1.5
