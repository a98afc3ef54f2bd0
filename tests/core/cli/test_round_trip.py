"""A newcomer's round trip from the command line alone (issue 40): a face file written by
hand, drawn (PNG, SVG, DXF read back with the same vertices), mapped, compared with the
X-Face at another width, and swept beside a second file, the file's name in every output."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from xface_core.cli import main
from xface_core.facefile import load_face

#: A trapezoid tooth of width 5 cm, written as a designer would write it.
TRAPEZOID = """\
xface_face: 1
name: trapezoid tooth
width: 0.05
mated_distance: 2.0
mirror_symmetric: true
layers:
  - base:   [[-0.5, -1.0], [0.5, -1.0], [0.5, 0.0], [0.2, 0.3], [-0.2, 0.3], [-0.5, 0.0]]
    moving: [[-0.5, -1.0], [0.5, -1.0], [0.5, -0.3], [0.2, 0.0], [-0.2, 0.0], [-0.5, -0.3]]
"""


def _json(capsys: pytest.CaptureFixture[str], argv: list[str]) -> object:
    assert main([*argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_a_face_file_goes_from_drawing_to_study_from_the_command_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    ezdxf = pytest.importorskip("ezdxf")
    face = tmp_path / "trap.yaml"
    face.write_text(TRAPEZOID, encoding="utf-8")
    design = load_face(face)

    # Drawn: PNG, SVG and a DXF whose polylines hold the file's vertices (in its unit).
    out = [tmp_path / "trap.png", tmp_path / "trap.svg", tmp_path / "trap.dxf"]
    assert main(["draw", "--face-file", str(face), "--png", str(out[0]), "--svg", str(out[1]),
                 "--dxf", str(out[2])]) == 0  # fmt: skip
    assert all(p.stat().st_size > 0 for p in out)
    assert "trapezoid tooth" in out[1].read_text(encoding="utf-8")
    doc = ezdxf.readfile(out[2])
    base = [e for e in doc.modelspace().query("LWPOLYLINE") if e.dxf.layer.startswith("BASE")]
    drawn = np.array(sorted(tuple(p[:2]) for e in base for p in e.get_points()))
    world = design.base_outline_world(0, 0.0) * design.width  # mated, in the file's unit
    assert np.allclose(drawn, np.array(sorted(map(tuple, world))), rtol=0.0, atol=1e-12)

    # Mapped, and compared with the X-Face (width 1) in units of D, names in the output.
    amap = _json(capsys, ["map", "--face-file", str(face), "--grid", "11", "--quiet"])
    assert isinstance(amap, dict)
    assert "trapezoid tooth" in json.dumps(amap)
    cmp = _json(capsys, ["compare", "--face-file", str(face), "--vs-face", "X", "--grid", "11"])
    assert isinstance(cmp, dict)
    assert "trapezoid tooth" in cmp["a"]["label"]
    assert cmp["a"]["M"] == amap["M"]

    # Swept beside a second file: one row each, named by their names.
    second = tmp_path / "wide.yaml"
    second.write_text(TRAPEZOID.replace("trapezoid tooth", "wide tooth").replace("0.2,", "0.3,"),
                      encoding="utf-8")  # fmt: skip
    table = tmp_path / "study.parquet"
    assert main(["sweep", "--face-file", f"{face},{second}", "--grid", "5", "--workers", "1",
                 "--quiet", "--out", str(table)]) == 0  # fmt: skip
    capsys.readouterr()
    pyarrow = pytest.importorskip("pyarrow.parquet")
    faces = sorted(pyarrow.read_table(table).column("face").to_pylist())
    assert faces == ["trapezoid tooth", "wide tooth"]
