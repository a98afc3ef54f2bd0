"""``xface optimize``: a small search writes the face file, pictures, drawing, cross-check and
summary a designer takes away, resumes from its folder, and refuses bad input in one line."""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path
from typing import Any

import ezdxf
import pytest

from xface_core.cli import main
from xface_core.cli.optimize import OPTIMIZE_CONVERGE_BY
from xface_core.codes import CROSSCHECK_CONVERGE_BY
from xface_core.facefile import load_face

SMALL = ["--grid", "7", "--budget", "12", "--popsize", "6", "--vertices", "2", "--workers", "1"]
#: The cross-check of a small search: 5 x 5 poses.
CHECK_SMALL = ["--crosscheck-grid", "5"]


@pytest.fixture(scope="module")
def searched(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any]]:
    out = tmp_path_factory.mktemp("optimize")
    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        assert main(["optimize", *SMALL, *CHECK_SMALL, "--out", str(out), "--json", "--quiet"]) == 0
    return out, json.loads(text.getvalue())


def test_optimize_writes_what_a_designer_takes_away(
    searched: tuple[Path, dict[str, Any]],
) -> None:
    out, summary = searched
    names = {"best.yaml", "best_map.png", "compare.png", "best_face.png", "best_face.dxf"}
    names |= {"crosscheck.json", "summary.json", "evaluations.parquet"}
    assert names <= {p.name for p in out.iterdir()}
    assert json.loads((out / "summary.json").read_text()) == summary


def test_the_winner_s_cross_check_converges_cell_by_cell_by_default(
    searched: tuple[Path, dict[str, Any]],
) -> None:
    out, _ = searched
    check = json.loads((out / "crosscheck.json").read_text())
    assert OPTIMIZE_CONVERGE_BY in CROSSCHECK_CONVERGE_BY
    assert check["converge_by"] == OPTIMIZE_CONVERGE_BY == "cells"
    assert check["converged"] is not None  # the halvings ran: a converged check


def test_the_face_file_is_the_best_face_with_its_name(
    searched: tuple[Path, dict[str, Any]],
) -> None:
    out, summary = searched
    face = load_face(out / "best.yaml")
    best = summary["best"]
    assert face.name == best["name"]
    assert face.name.startswith("optimized profile (H/D 0.25, r_p 1")
    # Its first layer's profile is the one the summary reports (the polygon's top, reversed).
    top = face.base_layers[0][1:-1][::-1].tolist()
    assert top == best["profile"]


def test_the_dxf_reads_back_with_the_face_s_layers(
    searched: tuple[Path, dict[str, Any]],
) -> None:
    out, _ = searched
    doc = ezdxf.readfile(out / "best_face.dxf")
    assert len(list(doc.modelspace().query("LWPOLYLINE"))) > 0


def test_the_summary_compares_with_the_x_face_and_the_engine(
    searched: tuple[Path, dict[str, Any]],
) -> None:
    _, summary = searched
    x_face, best, check = summary["x_face"], summary["best"], summary["crosscheck"]
    assert best["score"] >= x_face["score"]
    assert best["M"] == best["row"]["M"]
    assert check["grid"] == 5
    assert check["unambiguous"] + check["ambiguous"] == 25
    assert 0.0 <= check["agreement"] <= 1.0
    assert summary["evaluations"] >= 12


def test_running_it_again_resumes_from_the_folder(
    searched: tuple[Path, dict[str, Any]], capsys: pytest.CaptureFixture[str]
) -> None:
    out, summary = searched
    args = ["optimize", *SMALL, "--out", str(out), "--json", "--quiet", "--no-crosscheck"]
    assert main(args) == 0
    again = json.loads(capsys.readouterr().out)
    assert again["simulated"] == 0
    assert again["best"]["point"] == summary["best"]["point"]


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--vertices", "0"], "vertices must be an integer"),
        (["--min-feature", "0.3"], "min_feature must be in"),
        (["--criterion", "seat_probability"], "needs --sigma-x and --sigma-theta"),
        (["--budget", "0"], "budget must be an integer"),
        (["--max-wall-deg", "5"], "would not contain the X-Face"),
        (["--crosscheck-grid", "4"], "--crosscheck-grid must be an odd integer >= 3"),
        (
            ["--no-crosscheck", "--crosscheck-converge-by", "cells"],
            "--crosscheck-converge-by set how the Chipmunk2D check runs, and --no-crosscheck",
        ),
        (
            ["--no-crosscheck", "--crosscheck-grid", "41"],
            "--crosscheck-grid set how the Chipmunk2D check runs, and --no-crosscheck",
        ),
    ],
)
def test_bad_input_is_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: list[str], words: str
) -> None:
    code = main(["optimize", *SMALL, "--out", str(tmp_path / "o"), *extra])
    err = capsys.readouterr().err
    assert code == 2
    assert words in err
    assert err.count("\n") == 1
    assert "Traceback" not in err


def test_a_file_in_place_of_the_folder_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    file = tmp_path / "taken"
    file.write_text("mine\n")
    assert main(["optimize", *SMALL, "--out", str(file), "--no-crosscheck"]) == 2
    assert "cannot write the search to" in capsys.readouterr().err
    assert file.read_text() == "mine\n"
