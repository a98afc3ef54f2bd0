"""suggest_approach: a correction that meets the requirement, and none when it already does."""

from __future__ import annotations

import math

import numpy as np
import pytest

import xface_core as xf


def test_correction_reaches_the_probability(coarse_v_atlas: xf.AcceptanceAtlas) -> None:
    design = coarse_v_atlas.design
    cov = np.diag([0.05**2, 0.05**2])
    assert xf.seat_probability(design, 0.3, 0.4, cov, atlas=coarse_v_atlas) < 0.5
    s = xf.suggest_approach(design, 0.3, 0.4, cov, level=0.9, atlas=coarse_v_atlas)
    assert s.reached
    assert s.metric == "mahalanobis"
    p = xf.seat_probability(design, 0.3 + s.dx, 0.4 + s.dtheta, cov, atlas=coarse_v_atlas)
    assert p >= 0.9
    assert s.distance == pytest.approx(math.hypot(s.dx / 0.05, s.dtheta / 0.05), rel=1e-5)


def test_correction_reaches_the_margins(coarse_v_atlas: xf.AcceptanceAtlas) -> None:
    design = coarse_v_atlas.design
    s = xf.suggest_approach(
        design, 0.3, 0.4, min_lateral=0.05, min_angle=0.05, atlas=coarse_v_atlas
    )
    assert s.reached
    assert s.metric == "scaled"
    assert s.distance > 0
    p = xf.predict(design, 0.3 + s.dx, 0.4 + s.dtheta, path=False, margins=True)
    assert p.seated
    assert p.margins is not None
    assert p.margins.lateral >= 0.05
    assert p.margins.angle >= 0.05


def test_pose_already_meeting_the_level_needs_no_correction(
    coarse_v_atlas: xf.AcceptanceAtlas,
) -> None:
    s = xf.suggest_approach(coarse_v_atlas.design, 0.0, 0.0, np.eye(2) * 1e-4, atlas=coarse_v_atlas)
    assert (s.dx, s.dtheta, s.distance, s.reached) == (0.0, 0.0, 0.0, True)


def test_level_out_of_range_is_refused(coarse_v_atlas: xf.AcceptanceAtlas) -> None:
    with pytest.raises(xf.XfaceValueError, match="level"):
        xf.suggest_approach(
            coarse_v_atlas.design, 0.0, 0.0, np.eye(2), level=1.0, atlas=coarse_v_atlas
        )
