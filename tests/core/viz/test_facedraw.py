"""Drawings of a design (xface_core.viz.facedraw, xface_core.viz.facecad): the outlines are
the design's polygons, mated and at predict's start pose; pictures and DXF files read back."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import ezdxf
import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

from xface_core.errors import InputError
from xface_core.facefile import load_face, save_face
from xface_core.geometry import FaceDesign, custom_face, s_face, v_face, x_face
from xface_core.predict import predict
from xface_core.viz.facecad import dxf_document, save_face_dxf
from xface_core.viz.facedraw import (
    MAX_LABEL_CHARS,
    FaceDrawing,
    PartOutline,
    draw_face,
    face_drawing,
    save_face_picture,
)

#: A lopsided custom face (docs/facefile.md's example), one layer.
LOPSIDED = custom_face(
    [[[-0.5, -1.0], [0.5, -1.0], [0.5, 1.3], [0.1, 1.0], [-0.5, 1.3]]],
    [[[-0.5, -1.0], [0.5, -1.0], [0.5, 1.0], [-0.1, 1.3], [-0.5, 1.0]]],
    mated_distance=2.3,
    width=0.04,
)


def _outline(parts: tuple[PartOutline, ...], part: str, layer: int) -> np.ndarray:
    (found,) = [o.vertices for o in parts if o.part == part and o.layer == layer]
    return found


def _dxf_polylines(doc: ezdxf.document.Drawing) -> dict[str, np.ndarray]:
    """Every LWPOLYLINE's (x, y) vertices by its layer (one polyline per layer)."""
    found: dict[str, np.ndarray] = {}
    for entity in doc.modelspace().query("LWPOLYLINE"):
        assert entity.closed
        assert entity.dxf.layer not in found
        found[entity.dxf.layer] = np.array(list(entity.get_points("xy")), dtype=np.float64)
    return found


@pytest.mark.parametrize("design", [x_face(0.25, 1.0), v_face(0.5, 2.0, width=0.05), LOPSIDED])
def test_mated_outlines_are_the_designs_polygons_in_its_length_unit(design: FaceDesign) -> None:
    drawing = face_drawing(design)
    w, L = design.width, design.mated_distance
    for k in range(design.n_layers):
        base = _outline(drawing.mated.outlines, "base", k)
        moving = _outline(drawing.mated.outlines, "moving", k)
        np.testing.assert_allclose(base, design.base_layers[k] * w, rtol=0, atol=1e-15)
        # The moving part is turned half a turn, its pivot at (0, L): v -> (0, L) - v.
        expected = (np.array([0.0, L]) - design.moving_layers[k]) * w
        np.testing.assert_allclose(moving, expected, rtol=0, atol=1e-15)
    assert drawing.mated.base_pivot == (0.0, 0.0)
    assert drawing.mated.moving_pivot == pytest.approx((0.0, L * w), abs=1e-15)
    assert drawing.start is None


@pytest.mark.parametrize(
    ("design", "x0", "theta0"),
    [
        (x_face(0.25, 1.0), 0.3, 0.2),
        (s_face(0.5, 0.5, width=0.05), -0.01, -0.4),
        (LOPSIDED, 0.005, 0.3),
    ],
)
def test_start_pose_puts_the_moving_part_where_predict_starts(
    design: FaceDesign, x0: float, theta0: float
) -> None:
    drawing = face_drawing(design, pose=(x0, theta0))
    assert drawing.start is not None
    assert drawing.start_pose is not None
    path = predict(design, x0, theta0).path
    assert path is not None
    w = design.width
    x_m, y_m = path.pivot_m[0]
    assert drawing.start_pose.y_start == pytest.approx(y_m, abs=1e-12)
    for k in range(design.n_layers):
        moving = design.moving_outline_path(k, x_m / w, [y_m / w], [path.phi_m[0]])[0] * w
        base = design.base_outline_path(k, [path.phi_b[0]])[0] * w
        np.testing.assert_allclose(
            _outline(drawing.start.outlines, "moving", k), moving, atol=1e-12
        )
        np.testing.assert_allclose(_outline(drawing.start.outlines, "base", k), base, atol=1e-12)
    assert drawing.start.moving_pivot == pytest.approx((x_m, y_m), abs=1e-12)


@settings(max_examples=40, deadline=None)
@given(
    x0=st.floats(-0.9, 0.9),
    theta0=st.floats(-math.pi / 2, math.pi / 2),
    layer=st.integers(0, 1),
)
def test_start_pose_is_a_rigid_move_of_the_mated_part_clear_of_the_base(
    x0: float, theta0: float, layer: int
) -> None:
    design = x_face(0.25, 0.5)
    drawing = face_drawing(design, pose=(x0, theta0))
    assert drawing.start is not None
    mated = _outline(drawing.mated.outlines, "moving", layer)
    start = _outline(drawing.start.outlines, "moving", layer)
    # Rigid: every distance between two vertices is kept.
    pairwise = [np.linalg.norm(p[:, None] - p[None, :], axis=-1) for p in (mated, start)]
    np.testing.assert_allclose(pairwise[0], pairwise[1], atol=1e-12)
    # Predict's default start is just clear of the base: the parts do not touch.
    base = _outline(drawing.start.outlines, "base", layer)
    assert shapely.distance(shapely.Polygon(base), shapely.Polygon(start)) > 0.0


@pytest.mark.parametrize(("x0", "theta0"), [(0.0, 2.0), (math.nan, 0.1), (0.1, math.inf)])
def test_a_pose_predict_refuses_is_refused(x0: float, theta0: float) -> None:
    with pytest.raises(InputError):
        face_drawing(x_face(0.25, 1.0), pose=(x0, theta0))


def test_unit_is_d_at_width_one_and_names_the_width_otherwise() -> None:
    assert face_drawing(x_face(0.25, 1.0)).unit == "D"
    assert face_drawing(LOPSIDED).unit == "length unit, D = 0.04"
    assert face_drawing(LOPSIDED, unit="m").unit == "m"


def test_png_and_svg_are_written_and_readable(tmp_path: Path) -> None:
    drawing = face_drawing(x_face(0.25, 1.0), pose=(0.3, 0.2))
    png = save_face_picture(drawing, tmp_path / "face.png")
    svg = save_face_picture(drawing, tmp_path / "face.svg")
    with Image.open(png) as image:
        image.load()
        assert image.format == "PNG"
        assert image.width > 400
        assert image.height > 300
    assert ET.parse(svg).getroot().tag == "{http://www.w3.org/2000/svg}svg"


def test_pictures_are_the_same_bytes_for_the_same_drawing(tmp_path: Path) -> None:
    for suffix in ("png", "svg"):
        first, second = tmp_path / f"a.{suffix}", tmp_path / f"b.{suffix}"
        save_face_picture(face_drawing(LOPSIDED, pose=(0.01, -0.3)), first)
        save_face_picture(face_drawing(LOPSIDED, pose=(0.01, -0.3)), second)
        assert first.read_bytes() == second.read_bytes()


def test_picture_shows_a_start_panel_only_with_a_pose() -> None:
    mated_only = draw_face(face_drawing(v_face(0.5, 1.0)))
    with_pose = draw_face(face_drawing(v_face(0.5, 1.0), pose=(0.2, -0.1)))
    assert [ax.get_title() for ax in mated_only.axes] == ["mated"]
    assert len(with_pose.axes) == 2
    assert with_pose.axes[0].get_title() == "mated"
    assert with_pose.axes[1].get_title().startswith("start: x0 = 0.2, theta0 = -0.1 rad")
    assert with_pose.axes[0].get_xlabel() == "x (D)"


def test_face_files_name_titles_the_picture(tmp_path: Path) -> None:
    path = save_face(LOPSIDED, tmp_path / "lop.yaml", name="lopsided notch")
    fig = draw_face(face_drawing(load_face(path)))
    assert fig.get_suptitle() == "lopsided notch"


@pytest.mark.parametrize("name", ["$\\nosuchcommand$ notch", "x $a^$ y", "$\\frac{1}$"])
def test_a_name_with_mathtext_characters_is_drawn_as_written(tmp_path: Path, name: str) -> None:
    drawing = face_drawing(LOPSIDED, name=name, unit="$\\mu$m$")
    save_face_picture(drawing, tmp_path / "f.png")  # mathtext would raise on each
    fig = draw_face(drawing)
    assert fig.get_suptitle() == name
    assert fig.axes[0].get_xlabel() == "x ($\\mu$m$)"


def test_a_long_name_on_many_lines_is_drawn_on_one_line_within_the_limit() -> None:
    name = "notch\n" + "x" * 5000
    drawing = face_drawing(LOPSIDED, name=name)
    assert drawing.title == "notch " + "x" * (MAX_LABEL_CHARS - 7) + "\u2026"
    assert len(drawing.title) == MAX_LABEL_CHARS
    assert face_drawing(LOPSIDED, name=" \n ").title == "custom face, L = 2.3 D"


def test_a_title_wider_than_the_panels_widens_the_picture(tmp_path: Path) -> None:
    short = save_face_picture(face_drawing(LOPSIDED, name="n"), tmp_path / "short.png")
    wide = face_drawing(LOPSIDED, name="w" * MAX_LABEL_CHARS)
    fig = draw_face(wide)
    title = fig.texts[0].get_window_extent(fig.canvas.get_renderer())
    assert title.x0 >= 0
    assert title.x1 <= fig.get_size_inches()[0] * fig.dpi
    with Image.open(short) as a, Image.open(save_face_picture(wide, tmp_path / "w.png")) as b:
        assert b.width > a.width
        assert b.height == a.height  # one line either way


def test_built_in_face_is_titled_by_its_label() -> None:
    fig = draw_face(face_drawing(x_face(0.25, 2.0)))
    assert fig.get_suptitle() == "X-Face, H/D = 0.25, r_p = 2 D"


def _read_dxf(drawing: FaceDrawing, tmp_path: Path) -> ezdxf.document.Drawing:
    path = save_face_dxf(drawing, tmp_path / "face.dxf")
    return ezdxf.readfile(path)


@pytest.mark.parametrize("design", [x_face(0.25, 1.0), v_face(0.5, 2.0, width=0.05), LOPSIDED])
def test_dxf_reads_back_with_the_designs_vertices_on_its_layers(
    design: FaceDesign, tmp_path: Path
) -> None:
    drawing = face_drawing(design, pose=(0.1 * design.width, 0.25))
    doc = _read_dxf(drawing, tmp_path)
    polylines = _dxf_polylines(doc)
    expected: dict[str, np.ndarray] = {}
    for k in range(design.n_layers):
        expected[f"BASE_L{k}"] = _outline(drawing.mated.outlines, "base", k)
        expected[f"MOVING_L{k}"] = _outline(drawing.mated.outlines, "moving", k)
        assert drawing.start is not None
        expected[f"MOVING_START_L{k}"] = _outline(drawing.start.outlines, "moving", k)
    assert sorted(polylines) == sorted(expected)
    for layer, vertices in expected.items():
        np.testing.assert_allclose(polylines[layer], vertices, rtol=0, atol=1e-12)
    # And against the design itself, not only the drawing: the mated base is the body frame.
    np.testing.assert_allclose(
        polylines["BASE_L0"], design.base_layers[0] * design.width, rtol=0, atol=1e-12
    )


def test_dxf_marks_the_pivots_as_points_on_their_own_layers(tmp_path: Path) -> None:
    design = x_face(0.25, 1.0)
    doc = _read_dxf(face_drawing(design, pose=(0.3, 0.2)), tmp_path)
    points: dict[str, list[tuple[float, float]]] = {}
    for point in doc.modelspace().query("POINT"):
        points.setdefault(point.dxf.layer, []).append(tuple(point.dxf.location)[:2])
    y_start = predict(design, 0.3, 0.2, path=False).y_start
    assert points["PIVOTS"] == [(0.0, 0.0), (0.0, pytest.approx(design.mated_distance))]
    assert points["PIVOTS_START"] == [(0.3, pytest.approx(y_start, abs=1e-12))]


def test_dxf_says_metres_only_for_a_drawing_in_m(tmp_path: Path) -> None:
    in_m = dxf_document(face_drawing(LOPSIDED, unit="m", name="lopsided notch"))
    in_d = dxf_document(face_drawing(x_face(0.25, 1.0)))
    assert in_m.header["$INSUNITS"] == 6
    assert in_d.header["$INSUNITS"] == 0
    custom = in_m.header.custom_vars
    assert (custom.get("xface_unit"), custom.get("xface_title")) == ("m", "lopsided notch")
    assert float(custom.get("xface_width")) == 0.04
    assert in_d.header.custom_vars.get("xface_unit") == "D"
    assert "lengths in D" in in_d.layers.get("MOVING_L0").description
