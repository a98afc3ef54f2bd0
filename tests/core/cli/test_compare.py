"""``xface compare``: its counts against two acceptance maps computed directly."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from xface_core.cli import main
from xface_core.codes import Outcome
from xface_core.geometry import make_face
from xface_core.maps.acceptance import acceptance_map
from xface_core.physics import Physics

GRID = ["--grid", "11"]


def _json(capsys: pytest.CaptureFixture[str], argv: list[str]) -> dict[str, object]:
    assert main(argv) == 0
    out: dict[str, object] = json.loads(capsys.readouterr().out)
    return out


def test_counts_match_two_acceptance_maps(capsys: pytest.CaptureFixture[str]) -> None:
    out = _json(
        capsys,
        ["compare", "--face", "X", "--h-over-d", "0.25", "--rp", "0.25", "--vs-face", "S",
         *GRID, "--json"],
    )  # fmt: skip
    a = acceptance_map(make_face("X", 0.25, 0.25), grid=11).outcomes == Outcome.SEATED
    b = acceptance_map(make_face("S", 0.25, 0.25), grid=11).outcomes == Outcome.SEATED
    assert out["seated"] == {
        "both": int(np.count_nonzero(a & b)),
        "only_a": int(np.count_nonzero(a & ~b)),
        "only_b": int(np.count_nonzero(~a & b)),
        "neither": int(np.count_nonzero(~a & ~b)),
    }


def test_vs_friction_changes_only_b(capsys: pytest.CaptureFixture[str]) -> None:
    out = _json(capsys, ["compare", "--vs-friction", "0.3", *GRID, "--json"])
    design = make_face("X", 0.25, 1.0)
    m_b = acceptance_map(design, grid=11, physics=Physics(friction=0.3)).M
    assert (out["a"]["M"], out["b"]["M"]) == (acceptance_map(design, grid=11).M, m_b)  # type: ignore[index]


def test_text_names_both_m_values(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["compare", "--vs-face", "V", *GRID]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("A  X-Face")
    assert lines[1].startswith("B  V-Face")
    assert "only in A" in lines[2]


def test_png_is_written(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["compare", "--vs-face", "V", *GRID, "--png", str(tmp_path / "c.png")]) == 0
    assert (tmp_path / "c.png").read_bytes()[:4] == b"\x89PNG"


def test_bad_b_value_is_one_error_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["compare", "--vs-friction", "-1", *GRID]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith("xface: error:")


# --- a designer's own face files -----------------------------------------------------------------


def _face_file(tmp_path: Path, stem: str, name: str | None, width: float) -> str:
    from xface_core.facefile import save_face

    path = tmp_path / f"{stem}.yaml"
    save_face(make_face("X", 0.25, 2.0, width=width), path, name=name)
    return str(path)


def test_compare_a_face_file_of_another_width_against_a_built_in_face(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    trap = _face_file(tmp_path, "trap", "trap", 0.05)
    out = _json(capsys, ["compare", "--face-file", trap, "--vs-face", "X", "--rp", "2",
                         *GRID, "--json"])  # fmt: skip
    # The file holds the X-Face H/D 0.25 r_p 2 at D = 0.05: in units of D, the same design.
    assert out["same_outcome"] == 121
    assert out["seated"]["only_a"] == out["seated"]["only_b"] == 0  # type: ignore[index]
    assert out["a"]["width"] == 0.05
    assert out["b"]["width"] == 1.0


def test_compare_across_widths_says_how_in_text(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    trap = _face_file(tmp_path, "trap", "trap", 0.05)
    assert main(["compare", "--vs-face-file", trap, *GRID]) == 0
    text = capsys.readouterr().out
    assert "A D=1, B D=0.05: compared in units of D" in text
    assert "--width" in text


def test_compare_names_each_face_file_by_its_name(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    one = _face_file(tmp_path, "one", "lopsided notch", 1.0)
    two = _face_file(tmp_path, "two", "deep trap", 1.0)
    out = _json(capsys, ["compare", "--face-file", one, "--vs-face-file", two, *GRID, "--json"])
    assert out["a"]["label"].startswith("lopsided notch D=1")  # type: ignore[index]
    assert out["b"]["label"].startswith("deep trap D=1")  # type: ignore[index]


def test_compare_calls_an_unnamed_face_file_by_its_file_name(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import yaml

    path = Path(_face_file(tmp_path, "unnamed_trap", None, 1.0))
    doc = yaml.safe_load(path.read_text())
    del doc["name"]
    path.write_text(yaml.safe_dump(doc))
    out = _json(capsys, ["compare", "--face-file", str(path), "--vs-face", "V", *GRID, "--json"])
    assert out["a"]["label"].startswith("unnamed_trap D=1")  # type: ignore[index]
