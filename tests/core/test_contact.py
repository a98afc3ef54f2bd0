"""Pair tables: built once per geometry, shared by equal designs, holding no design alive."""

from __future__ import annotations

import gc
import weakref

import numpy as np

import xface_core as xf
from xface_core import contact


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
