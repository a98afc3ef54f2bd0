"""Face designs: user polygons are validated into a clear GeometryError, never a crash later."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import xface_core as xf
from xface_core.errors import GeometryError
from xface_core.geometry import is_mirror_symmetric

SQUARE = [(-0.5, -1.0), (0.5, -1.0), (0.5, 0.5), (-0.5, 0.5)]


def test_a_closed_ring_is_the_same_polygon() -> None:
    ring = [*SQUARE, SQUARE[0]]
    design = xf.custom_face([ring], [ring], mated_distance=1.0)
    assert design.base_layers[0].shape == (4, 2)
    # Before: the repeated vertex made a zero-length edge and predict raised ZeroDivisionError.
    assert xf.predict(design, 0.1, 0.1).outcome is xf.Outcome.SEATED


def test_a_repeated_vertex_inside_the_ring_is_refused() -> None:
    doubled = [SQUARE[0], SQUARE[1], SQUARE[1], SQUARE[2], SQUARE[3]]
    with pytest.raises(GeometryError, match="vertices 1 and 2 coincide"):
        xf.custom_face([doubled], [SQUARE], mated_distance=1.0)


@pytest.mark.parametrize(
    "vertices",
    [
        [[0.0, 0.0], [1.0, 0.0, 3.0], [1.0, 1.0]],  # ragged
        [["a", "b"], [1.0, 0.0], [1.0, 1.0]],  # not numbers
    ],
)
def test_ragged_or_non_numeric_vertices_are_a_geometry_error(vertices: object) -> None:
    with pytest.raises(GeometryError, match="vertices must be numbers"):
        xf.custom_face([vertices], [SQUARE], mated_distance=1.0)  # type: ignore[list-item]


def test_geometry_error_is_a_value_error_for_callers_that_catch_those() -> None:
    with pytest.raises(ValueError, match="need an"):
        xf.custom_face([[(0.0, 0.0), (1.0, 0.0)]], [SQUARE], mated_distance=1.0)


# A flat-topped tooth and its socket, both mirror-symmetric (scripts/evidence/golden_maps.py).
TOOTH = [(-0.5, -1.0), (0.5, -1.0), (0.5, 0.0), (0.2, 0.0), (0.1, 0.3), (-0.1, 0.3),
         (-0.2, 0.0), (-0.5, 0.0)]  # fmt: skip
SOCKET = [(-0.5, -1.0), (0.5, -1.0), (0.5, 0.3), (0.2, 0.3), (0.1, 0.0), (-0.1, 0.0),
          (-0.2, 0.3), (-0.5, 0.3)]  # fmt: skip
# The same with the tooth's tip moved right: no longer mirror-symmetric.
LEANING_TOOTH = [(-0.5, -1.0), (0.5, -1.0), (0.5, 0.0), (0.2, 0.0), (0.15, 0.3), (-0.05, 0.3),
                 (-0.2, 0.0), (-0.5, 0.0)]  # fmt: skip
LEANING_SOCKET = [(-0.5, -1.0), (0.5, -1.0), (0.5, 0.3), (0.2, 0.3), (0.05, 0.0), (-0.15, 0.0),
                  (-0.2, 0.3), (-0.5, 0.3)]  # fmt: skip


def _mirrored(polygon: list[tuple[float, float]]) -> list[tuple[float, float]]:
    return [(-x, y) for x, y in polygon]


def test_a_false_mirror_symmetry_claim_is_refused() -> None:
    with pytest.raises(GeometryError, match="mirror_symmetric is claimed but the design is not"):
        xf.custom_face([LEANING_TOOTH], [LEANING_SOCKET], mated_distance=0.3, mirror_symmetric=True)


def test_a_mirror_symmetry_claim_is_checked_per_layer_pair() -> None:
    # The bases (A, mirror A) and the movings (B, mirror B) are each closed under the mirror,
    # but the layer (A, B) mirrored, (mirror A, mirror B), is no layer: contacts only happen
    # within a layer, so the design is not mirror-symmetric.
    a, b = LEANING_TOOTH, LEANING_SOCKET
    with pytest.raises(GeometryError, match="mirror_symmetric is claimed"):
        xf.custom_face(
            [a, _mirrored(a), a],
            [b, b, _mirrored(b)],
            mated_distance=1.0,
            mirror_symmetric=True,
        )


def test_a_true_mirror_symmetry_claim_holds_in_any_vertex_order_and_layer_order() -> None:
    x = xf.x_face(0.25, 2.0)
    # The X-Face's layers swap under the mirror; give them clockwise, from another vertex.
    base = [np.roll(p[::-1], 2, axis=0) for p in x.base_layers]
    design = xf.custom_face(base, list(x.moving_layers), mated_distance=4.25, mirror_symmetric=True)
    assert design.mirror_symmetric
    assert xf.custom_face([TOOTH], [SOCKET], mated_distance=0.3, mirror_symmetric=True)


def test_the_mirror_check_agrees_with_the_built_in_faces() -> None:
    for factory in (xf.x_face, xf.v_face, xf.s_face):
        for h_over_d, r_p in ((0.1, 0.0), (0.25, 2.0), (1.0, 1.0), (3.0, 0.5)):
            d = factory(h_over_d, r_p)
            assert is_mirror_symmetric(d.base_layers, d.moving_layers) == d.mirror_symmetric


@settings(max_examples=60)
@given(
    heights=st.lists(st.floats(0.0, 1.0), min_size=1, max_size=5),
    apex=st.booleans(),
    nudge=st.floats(1e-6, 0.01),
    which=st.integers(0, 100),
)
def test_a_profile_built_mirror_symmetric_passes_and_one_nudged_vertex_fails(
    heights: list[float], apex: bool, nudge: float, which: int
) -> None:
    # The top profile at x = +-k / (2 n), k = 1..n, the same height on both sides (and a vertex
    # on the axis if apex): mirror-symmetric by construction.
    n = len(heights)
    right = [((k + 1) / (2 * n + 1), y) for k, y in enumerate(heights)]
    top = [(-x, y) for x, y in reversed(right)] + ([(0.0, 0.5)] if apex else []) + right
    polygon = [(0.5, -1.0), *reversed(top), (-0.5, -1.0)]
    assert xf.custom_face([polygon], [polygon], mated_distance=10.0, mirror_symmetric=True)
    # Nudging one vertex off the axis vertically breaks the symmetry (its partner stays).
    off_axis = [k for k, (x, _) in enumerate(polygon) if x != 0.0]
    k = off_axis[which % len(off_axis)]
    nudged = list(polygon)
    nudged[k] = (polygon[k][0], polygon[k][1] + nudge)
    with pytest.raises(GeometryError, match="mirror_symmetric is claimed"):
        xf.custom_face([nudged], [polygon], mated_distance=10.0, mirror_symmetric=True)


def test_a_vertex_beyond_the_coordinate_limit_is_refused() -> None:
    # Before: accepted, then predict raised ZeroDivisionError (squared lengths overflow).
    far = [(-0.5, -1.0), (0.5, -1.0), (1e200, 1e154), (-0.5, 0.5)]
    with pytest.raises(GeometryError, match=r"beyond \+-100 D \(MAX_CUSTOM_COORDINATE"):
        xf.custom_face([far], [SQUARE], mated_distance=10.0)


def test_an_integer_vertex_too_large_for_a_float_is_a_geometry_error() -> None:
    huge = [(-0.5, -1.0), (0.5, -1.0), (0.5, 10**400), (-0.5, 0.5)]
    with pytest.raises(GeometryError, match="vertices must be numbers"):
        xf.custom_face([huge], [SQUARE], mated_distance=10.0)
