"""Face designs: user polygons are validated into a clear GeometryError, never a crash later."""

from __future__ import annotations

import pytest

import xface_core as xf
from xface_core.errors import GeometryError

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
