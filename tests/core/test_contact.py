"""Pair tables: built once per geometry, shared by equal designs, holding no design alive;
which pair of two that meet at the same corners judges their crossing."""

from __future__ import annotations

import gc
import weakref

import numpy as np
import pytest

import xface_core as xf
from xface_core import contact
from xface_core._engine.pairs import COL_CORNER_TESTED, COL_EDGE_LENGTH
from xface_core.contact import MOVING_VERTEX, pair_table


def test_equal_designs_share_one_table() -> None:
    assert contact.pair_table(xf.x_face(0.25, 2.0)) is contact.pair_table(xf.x_face(0.25, 2.0))


def test_a_copy_at_another_width_shares_the_table() -> None:
    design = xf.v_face(0.5, 1.0)
    assert contact.pair_table(design.with_width(0.05)) is contact.pair_table(design)


def test_different_geometry_gets_its_own_table() -> None:
    a = contact.pair_table(xf.x_face(0.25, 2.0))
    b = contact.pair_table(xf.x_face(0.25, 3.0))
    assert a is not b
    assert not np.array_equal(a.data, b.data)


def test_the_cache_keeps_no_design_alive() -> None:
    design = xf.s_face(0.7, 1.3)
    contact.pair_table(design)
    ref = weakref.ref(design)
    del design
    gc.collect()
    assert ref() is None


def test_the_cache_is_bounded() -> None:
    for k in range(contact.CACHE_SIZE + 5):
        contact.pair_table(xf.x_face(0.25 + 0.001 * k, 1.0))
    assert len(contact._cache) == contact.CACHE_SIZE


def test_the_per_design_shortcut_is_bounded_and_gives_the_cached_table() -> None:
    designs = [xf.x_face(0.5 + 0.001 * k, 1.0) for k in range(contact.CACHE_SIZE + 5)]
    tables = [contact.pair_table(d) for d in designs]
    assert len(contact._by_design) <= contact.CACHE_SIZE
    for design, table in zip(designs, tables, strict=True):  # dropped ones are rebuilt
        np.testing.assert_array_equal(contact.pair_table(design).data, table.data)
    design = designs[-1]
    assert contact.pair_table(design) is contact._by_design[design]
    assert contact.pair_table(xf.x_face(0.5 + 0.001 * (contact.CACHE_SIZE + 4), 1.0)) is (
        contact.pair_table(design)
    )


def test_clear_cache_rebuilds_an_equal_table() -> None:
    design = xf.x_face(0.25, 2.0)
    before = contact.pair_table(design)
    contact.clear_cache()
    assert not contact._by_design
    after = contact.pair_table(design)
    assert after is not before
    np.testing.assert_array_equal(after.data, before.data)


def test_the_engine_model_is_built_from_the_same_arrays() -> None:
    table = contact.pair_table(xf.x_face(0.25, 2.0))
    assert table.model.pairs is table.data
    assert table.model.mated_distance == 4.25


# ---- which pair of a meeting of two corners judges their crossing -------------------------

_SQUARE = [(-0.5, -1.0), (0.5, -1.0), (0.5, 0.5), (-0.5, 0.5)]
_TALL = [(-0.4, 0.0), (0.3, 0.0), (0.3, 1.5), (-0.4, 1.5)]
_TRIANGLE = [(-0.4, -0.9), (0.4, -0.9), (0.0, -0.2)]


@pytest.mark.parametrize(
    "design",
    [
        xf.x_face(0.25, 2.0),
        xf.v_face(0.5, 1.0),
        xf.s_face(0.5, 1.0),
        xf.custom_face([_SQUARE, _TRIANGLE], [_TRIANGLE, _TALL], mated_distance=2.0),
    ],
    ids=["X", "V", "S", "custom, two layers of 4 and 3 vertices"],
)
def test_each_meeting_of_corners_is_judged_by_the_pair_with_the_longer_edge(
    design: xf.FaceDesign,
) -> None:
    """Found by geometry, not by the row arithmetic the table uses: a pair's partner has this
    pair's edge start as its vertex and this pair's vertex as its edge start, in the same
    layer; exactly one of the two judges, the longer edge's (the moving vertex's on a tie)."""
    t = pair_table(design).data
    for i, row in enumerate(t):
        (j,) = np.flatnonzero(
            (t[:, 0] != row[0])
            & (t[:, 9] == row[9])
            & np.all(t[:, 1:3] == row[3:5], axis=1)
            & np.all(t[:, 3:5] == row[1:3], axis=1)
        )
        mine, theirs = row[COL_EDGE_LENGTH], t[j, COL_EDGE_LENGTH]
        judges = mine > theirs or (mine == theirs and row[0] == MOVING_VERTEX)
        assert row[COL_CORNER_TESTED] == (1.0 if judges else 0.0), i
        assert row[COL_CORNER_TESTED] + t[j, COL_CORNER_TESTED] == 1.0
