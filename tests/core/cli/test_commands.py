"""The xface command line: the JSON contracts and the plain output."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from xface_core.cli import main


def _json(capsys: pytest.CaptureFixture[str], argv: list[str]) -> dict:  # type: ignore[type-arg]
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)


def test_predict_json_has_outcome_reason_margins_path(capsys: pytest.CaptureFixture[str]) -> None:
    out = _json(
        capsys,
        [
            "predict",
            "--face",
            "X",
            "--h-over-d",
            "0.25",
            "--rp",
            "2",
            "--x0",
            "0.3",
            "--theta0",
            "0.2",
            "--json",
        ],
    )
    assert out["outcome"] == "SEATED"
    assert out["seated"] is True
    assert out["reason"]
    assert set(out["margins"]) >= {"lateral", "angle"}
    assert out["path"]["samples"] == len(out["path"]["phi_m"])


def test_map_json_contract(capsys: pytest.CaptureFixture[str]) -> None:
    out = _json(capsys, ["map", "--face", "X", "--h-over-d", "0.0625", "--rp", "1", "--json"])
    assert len(out["x0"]) == 41
    assert len(out["theta0"]) == 41
    assert out["x0"][0] == -1.0
    assert out["x0"][-1] == 1.0
    assert out["theta0"][0] == pytest.approx(-math.pi / 2)
    assert len(out["outcomes"]) == 41
    assert len(out["outcomes"][0]) == 41
    assert out["M"] == sum(row.count("SEATED") for row in out["outcomes"])


def test_map_width_scales_x0(capsys: pytest.CaptureFixture[str]) -> None:
    out = _json(capsys, ["map", "--face", "V", "--grid", "11", "--width", "0.05", "--json"])
    assert out["x0"][-1] == pytest.approx(0.05)


def test_table_bound_json_matches_table_iii(capsys: pytest.CaptureFixture[str]) -> None:
    from xface_core.maps.paper import paper_table

    out = _json(capsys, ["table", "--face", "V", "--method", "bound", "--json"])
    assert len(out["h_over_d"]) == 11
    assert len(out["r_p"]) == 11
    assert out["M"] == paper_table("V").M.astype(int).tolist()


def test_table_plain_prints_paper_and_difference(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["table", "--face", "V", "--method", "bound"]) == 0
    text = capsys.readouterr().out
    assert "739/739 (  +0)" in text
    assert "cells equal to the paper: 121 of 121" in text


def test_faces_turned_away_are_invalid_input_with_the_reason(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["predict", "--x0", "0", "--theta0", "2.0"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("xface: INVALID_INPUT: |theta0| = 2 rad > pi/2")
    assert "do not face each other" in err


def test_bad_design_is_a_clear_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["predict", "--h-over-d", "-1", "--x0", "0", "--theta0", "0"]) == 2
    assert "h_over_d" in capsys.readouterr().err


def test_map_png_is_written(tmp_path, capsys: pytest.CaptureFixture[str]) -> None:  # type: ignore[no-untyped-def]
    png = tmp_path / "map.png"
    assert main(["map", "--face", "S", "--grid", "11", "--png", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_friction_reaches_the_simulation(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["predict", "--x0", "0.3", "--theta0", "0.2", "--no-margins", "--json"]
    assert _json(capsys, argv)["outcome"] == "SEATED"
    assert _json(capsys, [*argv, "--friction", "0.5"])["outcome"] == "BAD_MATE"
    grid = ["map", "--face", "X", "--grid", "11", "--json"]
    assert _json(capsys, [*grid, "--friction", "0.5"])["M"] < _json(capsys, grid)["M"]


@pytest.mark.parametrize(
    ("argv", "field"),
    [
        (["predict", "--x0", "0", "--theta0", "0", "--friction", "-1"], "friction"),
        (["map", "--grid", "11", "--friction", "nan"], "friction"),
        (["map", "--grid", "11", "--damping-ratio", "0"], "damping_ratio"),
        (["table", "--face", "V", "--friction", "11"], "friction"),
    ],
)
def test_bad_physics_is_a_clear_error(
    capsys: pytest.CaptureFixture[str], argv: list[str], field: str
) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("xface: error: ")
    assert field in err


def test_table_bound_takes_only_the_papers_physics(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["table", "--face", "V", "--method", "bound", "--friction", "0.2"]) == 2
    assert "--method sim" in capsys.readouterr().err


def test_pose_noise_gives_the_seat_probability_and_a_correction(
    capsys: pytest.CaptureFixture[str],
) -> None:
    import xface_core as xf

    argv = ["predict", "--rp", "2", "--x0", "0.3", "--theta0", "0.2", "--no-margins"]
    out = _json(capsys, [*argv, "--sigma-x", "0.05", "--sigma-theta", "0.1", "--json"])
    u = out["uncertainty"]
    cov = [[0.05**2, 0.0], [0.0, 0.1**2]]
    assert u["seat_probability"] == xf.seat_probability(xf.x_face(0.25, 2.0), 0.3, 0.2, cov)
    assert u["seat_probability"] < 0.9  # so a correction is suggested
    assert u["suggestion"]["reached"]
    assert u["suggestion"]["seat_probability"] >= 0.9


def test_negative_pose_noise_is_a_clear_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["predict", "--x0", "0", "--theta0", "0", "--sigma-x", "-1"]) == 2
    assert "xface: error: --sigma-x and --sigma-theta must be finite" in capsys.readouterr().err


def test_pose_noise_whose_square_overflows_names_the_flags(
    capsys: pytest.CaptureFixture[str],
) -> None:
    argv = ["predict", "--x0", "0", "--theta0", "0", "--sigma-x", "1e300", "--sigma-theta", "0"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    expected = (
        "xface: error: --sigma-x 1e+300 and --sigma-theta 0: their squares (the covariance) "
        "overflow; at most about 1e150"
    )
    assert err == [expected]


def test_table_says_where_the_simulation_departs_from_the_paper(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from dataclasses import replace

    from xface_core.cli import commands
    from xface_core.maps.acceptance import m_table

    # A simulated table takes minutes: the bound's numbers, labelled as a simulation's.
    def fake_sim(face: str, **kwargs: object) -> object:
        return replace(m_table(face, method="bound", theta_kind="paper"), method="sim")

    monkeypatch.setattr(commands, "m_table", fake_sim)
    assert main(["table", "--face", "V", "--quiet"]) == 0
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert "departs from the paper" in last
    assert "docs/paper.md" in last


def test_predict_text_gives_angles_in_rad_and_deg(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["predict", "--x0", "0", "--theta0", "0.2", "--no-margins"]) == 0
    assert "theta0=+0.2 rad (+11.4592 deg)" in capsys.readouterr().out


def test_predict_text_names_a_face_files_width_as_the_unit(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from xface_core.facefile import save_face
    from xface_core.geometry import x_face

    path = tmp_path / "trap.yaml"
    save_face(x_face(0.25, 2.0, width=0.05), path, name="trap")
    assert main(["predict", "--face-file", str(path), "--x0", "0.01", "--theta0", "0.2",
                 "--no-margins"]) == 0  # fmt: skip
    text = capsys.readouterr().out
    assert text.startswith("trap D=0.05\n")
    assert "length units" not in text
    assert "x0=+0.01 (+0.2 D)" in text
