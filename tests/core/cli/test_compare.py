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
