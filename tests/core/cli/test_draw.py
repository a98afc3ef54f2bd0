"""``xface draw``: the files it writes hold the design's outlines (mated and at predict's
start pose), named as asked; what it refuses, before writing anything."""

from __future__ import annotations

import sys
from pathlib import Path

import ezdxf
import numpy as np
import pytest
from PIL import Image

from xface_core.cli import main
from xface_core.facefile import save_face
from xface_core.geometry import custom_face, make_face
from xface_core.predict import predict

#: docs/facefile.md's lopsided notch, one layer, D = 0.04.
LOPSIDED = custom_face(
    [[[-0.5, -1.0], [0.5, -1.0], [0.5, 1.3], [0.1, 1.0], [-0.5, 1.3]]],
    [[[-0.5, -1.0], [0.5, -1.0], [0.5, 1.0], [-0.1, 1.3], [-0.5, 1.0]]],
    mated_distance=2.3,
    width=0.04,
)


def _polylines(path: Path) -> dict[str, np.ndarray]:
    doc = ezdxf.readfile(path)
    return {
        e.dxf.layer: np.array(list(e.get_points("xy")), dtype=np.float64)
        for e in doc.modelspace().query("LWPOLYLINE")
    }


def test_draw_writes_a_png_an_svg_and_a_dxf(tmp_path: Path) -> None:
    png, svg, dxf = tmp_path / "f.png", tmp_path / "f.svg", tmp_path / "f.dxf"
    argv = ["draw", "--face", "V", "--png", str(png), "--svg", str(svg), "--dxf", str(dxf)]
    assert main(argv) == 0
    with Image.open(png) as image:
        image.load()
        assert image.format == "PNG"
    assert svg.read_text(encoding="utf-8").lstrip().startswith("<?xml")
    assert sorted(_polylines(dxf)) == ["BASE_L0", "MOVING_L0"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.dxf", "f.png", "f.svg"]


def test_draw_dxf_holds_the_designs_vertices_in_its_length_unit(tmp_path: Path) -> None:
    dxf = tmp_path / "x.dxf"
    argv = ["draw", "--face", "X", "--h-over-d", "0.5", "--rp", "2", "--width", "0.05"]
    assert main([*argv, "--dxf", str(dxf)]) == 0
    design = make_face("X", 0.5, 2.0, width=0.05)
    polylines = _polylines(dxf)
    assert sorted(polylines) == ["BASE_L0", "BASE_L1", "MOVING_L0", "MOVING_L1"]
    L = design.mated_distance
    for k in range(2):
        base = design.base_layers[k] * 0.05
        moving = (np.array([0.0, L]) - design.moving_layers[k]) * 0.05
        np.testing.assert_allclose(polylines[f"BASE_L{k}"], base, rtol=0, atol=1e-12)
        np.testing.assert_allclose(polylines[f"MOVING_L{k}"], moving, rtol=0, atol=1e-12)


def test_draw_pose_moves_the_moving_part_to_predicts_start(tmp_path: Path) -> None:
    dxf = tmp_path / "pose.dxf"
    argv = ["draw", "--face", "S", "--width", "0.05", "--x0", "-0.01", "--theta0", "-0.3"]
    assert main([*argv, "--dxf", str(dxf)]) == 0
    design = make_face("S", 0.25, 1.0, width=0.05)
    path = predict(design, -0.01, -0.3).path
    assert path is not None
    x_m, y_m = path.pivot_m[0]
    start = design.moving_outline_path(0, x_m / 0.05, [y_m / 0.05], [path.phi_m[0]])[0] * 0.05
    polylines = _polylines(dxf)
    np.testing.assert_allclose(polylines["MOVING_START_L0"], start, rtol=0, atol=1e-12)
    # The mated part stays where it was: the pose adds a layer, it moves nothing else.
    mated = (np.array([0.0, design.mated_distance]) - design.moving_layers[0]) * 0.05
    np.testing.assert_allclose(polylines["MOVING_L0"], mated, rtol=0, atol=1e-12)


def test_draw_titles_the_drawing_with_the_face_files_name(tmp_path: Path) -> None:
    face = save_face(LOPSIDED, tmp_path / "lop.yaml", name="lopsided notch")
    svg, dxf = tmp_path / "lop.svg", tmp_path / "lop.dxf"
    assert main(["draw", "--face-file", str(face), "--svg", str(svg), "--dxf", str(dxf)]) == 0
    # matplotlib's SVG keeps each text drawn as paths in a comment beside it.
    assert "<!-- lopsided notch -->" in svg.read_text(encoding="utf-8")
    header = ezdxf.readfile(dxf).header
    assert header.custom_vars.get("xface_title") == "lopsided notch"
    assert header.custom_vars.get("xface_unit") == "length unit, D = 0.04"


@pytest.mark.parametrize("width", ["nan", "inf", "0", "-0.04"])
def test_draw_refuses_a_width_that_is_not_finite_and_positive_for_a_face_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], width: str
) -> None:
    face = save_face(LOPSIDED, tmp_path / "lop.yaml")
    png = tmp_path / "f.png"
    assert main(["draw", "--face-file", str(face), "--width", width, "--png", str(png)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("xface: error: width must be")
    assert err.count("\n") == 1
    assert not png.exists()


def test_draw_without_an_output_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["draw", "--face", "V"]) == 2
    assert capsys.readouterr().err == (
        "xface: error: draw needs at least one of --png, --svg, --dxf\n"
    )


@pytest.mark.parametrize(
    ("option", "name", "what"),
    [
        ("--png", "face.svg", "a PNG picture: name it *.png"),
        ("--svg", "face.png", "an SVG picture: name it *.svg"),
        ("--dxf", "face.dwg", "a DXF drawing: name it *.dxf"),
        ("--dxf", "face", "a DXF drawing: name it *.dxf"),
    ],
)
def test_draw_refuses_an_output_named_for_another_format(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], option: str, name: str, what: str
) -> None:
    target = tmp_path / name
    assert main(["draw", option, str(target)]) == 2
    err = capsys.readouterr().err
    assert err == f"xface: error: {option} '{target}': {option} writes {what}\n"
    assert list(tmp_path.iterdir()) == []


def test_draw_with_half_a_pose_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["draw", "--x0", "0.1", "--png", str(tmp_path / "f.png")]) == 2
    assert "give both --x0 and --theta0" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_draw_refuses_a_pose_predict_refuses(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["draw", "--x0", "0.1", "--theta0", "2", "--png", str(tmp_path / "f.png")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("xface: error: |theta0| = 2 rad > pi/2")
    assert err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


def test_draw_dxf_without_the_cad_extra_exits_2_with_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    # As if ezdxf were not installed: importing it or any of its modules (and so facecad)
    # fails; monkeypatch puts them all back afterwards.
    for name in [m for m in sys.modules if m.partition(".")[0] == "ezdxf"]:
        monkeypatch.setitem(sys.modules, name, None)
    monkeypatch.delitem(sys.modules, "xface_core.viz.facecad", raising=False)
    png, dxf = tmp_path / "f.png", tmp_path / "f.dxf"
    assert main(["draw", "--png", str(png), "--dxf", str(dxf)]) == 2
    assert capsys.readouterr().err == (
        "xface: --dxf needs the cad extra: pip install '.[cad]' in the xface checkout\n"
    )
    assert list(tmp_path.iterdir()) == []  # not even the PNG
