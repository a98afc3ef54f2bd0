"""The contact-mechanics reproducers (tests/core/test_contact_mechanics.py) in the real
engine: on each cell xface and Chipmunk2D, sharp and rounded corners, agree on seating.

This is the sample of the accuracy table (docs/accuracy.md) that CI runs; the table itself
(`python scripts/evidence/accuracy_table.py`) takes tens of minutes.
"""

from __future__ import annotations

import math

import pytest

import xface_core as xf
from xface_core.crosscheck import crosscheck

PI = math.pi
STEEP_X = xf.x_face(0.6253735159602775, 0.0)
STEEP_POSE = (-0.6102404552338436, 1.5419709276006972)

CELLS = [
    # (design, physics, x0 in D, theta0): corners that slip past instead of pinning.
    (xf.v_face(0.32988, 2.0), xf.Physics(), -0.7, PI / 10),
    (xf.s_face(0.5, 1.0), xf.Physics(), -0.5, PI / 5),
    # Corners that slip and flush flanks that slide on: seats, not false jams.
    (xf.s_face(0.0625, 1.0), xf.Physics(), 0.6, -PI / 5),
    (xf.v_face(0.0625, 1.0), xf.Physics(), -0.9, 0.0),
    (xf.s_face(0.0625, 1.0), xf.Physics(), -0.5, -PI / 40),
    # Friction stopping a part that would turn away (a seat at mu 0.3, a jam at mu 0.2).
    (STEEP_X, xf.Physics(friction=0.3), *STEEP_POSE),
    (STEEP_X, xf.Physics(friction=0.2), *STEEP_POSE),
]  # fmt: skip


@pytest.mark.parametrize(("design", "physics", "x0", "theta0"), CELLS)
def test_xface_agrees_with_the_engine_on_a_reproducer_cell(
    design: xf.FaceDesign, physics: xf.Physics, x0: float, theta0: float
) -> None:
    r = crosscheck(design, physics, cells=[(x0, theta0)], workers=1)
    assert r.n_ambiguous == 0
    assert r.agreement == 1.0, r.disagreements
