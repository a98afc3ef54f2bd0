"""Margins: the distance to the nearest outcome flip along each axis."""

from __future__ import annotations

import xface_core as xf
from xface_core.margins import ANGLE_RESOLUTION, LATERAL_RESOLUTION


def test_lateral_margin_brackets_a_flip() -> None:
    design = xf.x_face(0.25, 2.0)
    p = xf.predict(design, 0.3, 0.2, margins=True)
    m = p.margins
    assert m is not None
    inside = xf.predict(design, 0.3 + m.lateral_plus - 2 * LATERAL_RESOLUTION, 0.2, path=False)
    outside = xf.predict(design, 0.3 + m.lateral_plus, 0.2, path=False)
    assert inside.outcome is p.outcome
    assert outside.outcome is not p.outcome


def test_angle_margin_brackets_a_flip() -> None:
    design = xf.v_face(0.5, 1.0)
    p = xf.predict(design, 0.1, 0.05, margins=True)
    m = p.margins
    assert m is not None
    inside = xf.predict(design, 0.1, 0.05 - m.angle_minus + 2 * ANGLE_RESOLUTION, path=False)
    outside = xf.predict(design, 0.1, 0.05 - m.angle_minus, path=False)
    assert inside.outcome is p.outcome
    assert outside.outcome is not p.outcome


def test_out_of_reach_pose_has_finite_lateral_margin() -> None:
    design = xf.x_face(0.25, 0.0)  # L = 0.25
    p = xf.predict(design, 0.5, 0.0, margins=True)
    assert p.margins is not None
    assert p.margins.lateral_minus <= 0.25 + LATERAL_RESOLUTION


def test_margins_are_searched_at_the_query_start_height() -> None:
    # A start below the base never touches (NO_CONTACT); its neighbours started there do
    # not either, so no flip lies within a scan step (it was +-9.8e-5 D when the neighbours
    # were simulated from the default start instead).
    design = xf.x_face(0.25, 2.0)
    p = xf.predict(design, 0.3, 0.2, y_start=-5.0, path=False, margins=True)
    assert p.outcome is xf.Outcome.NO_CONTACT
    assert p.margins is not None
    assert min(p.margins.lateral, p.margins.angle) > 0.025


def test_batch_start_height_matches_predict() -> None:
    design = xf.v_face(0.5, 1.0)
    for y in (-3.0, 4.0):
        single = xf.predict(design, 0.1, 0.05, y_start=y, path=False).outcome
        batch = xf.predict_batch(design, [0.1], [0.05], y_start=y).outcome[0]
        assert batch == single
