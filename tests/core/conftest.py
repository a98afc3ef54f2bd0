"""Fixtures shared by the atlas tests (margins, probability, approach)."""

from __future__ import annotations

import math

import pytest

import xface_core as xf
from xface_core.atlas.build import build_atlas


@pytest.fixture(scope="session")
def coarse_v_atlas() -> xf.AcceptanceAtlas:
    """V-Face H/D 0.5, r_p 1 (L = 2.5 D) on the coarse grid, default physics."""
    # Coarse (well under a second to build) to keep the suite fast; the full-size checks
    # are in scripts/evidence/check_atlas.py.
    return build_atlas(
        xf.v_face(0.5, 1.0), lateral_step=1 / 32, angle_step=math.pi / 128, angle_range=math.pi / 2
    )
