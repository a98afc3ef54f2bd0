"""``xface sweep`` and ``xface design``: a killed sweep resumes without computing a design
twice, bad input is one line on stderr with exit code 2, the search reproduces the table."""

from __future__ import annotations

import io
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from unittest import mock

import numpy as np
import pytest
from PIL import Image

import xface_core as xf
from xface_core.cli import main
from xface_core.cli.study import ProgressBar
from xface_core.study.run import StudyProgress, read_study
from xface_core.study.table import StudyFile

ROOT = Path(__file__).resolve().parents[3]

#: 36 designs on a 31 x 31 pose grid: several seconds of work on two workers, so that a kill
#: after the first rows lands midway.
SWEEP = ["sweep", "--face", "X,V,S", "--h-over-d", "0.25,0.5,1", "--rp", "0,1,2,3"]
SWEEP += ["--grid", "31", "--quiet", "--json"]
N_DESIGNS = 36


def _sweep_process(out: Path) -> subprocess.Popen[str]:
    path = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)
    return subprocess.Popen(
        [sys.executable, "-m", "xface_core.cli", *SWEEP, "--workers", "2", "--out", str(out)],
        env={**os.environ, "PYTHONPATH": path},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group: the kill reaches its workers too
    )


def _rows_on_disk(out: Path) -> int:
    parts = out.with_name(out.name + ".parts")
    return len(list(parts.glob("*.parquet"))) if parts.is_dir() else 0


def _wait_for_rows(proc: subprocess.Popen[str], out: Path, rows: int) -> None:
    deadline = time.monotonic() + 120
    while _rows_on_disk(out) < rows:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "no rows written"
        time.sleep(0.01)


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory: pytest.TempPathFactory) -> object:
    out = tmp_path_factory.mktemp("whole") / "study.parquet"
    assert main([*SWEEP, "--workers", "2", "--out", str(out)]) == 0
    return read_study(out, timing=False)


def _started_sweep(out: Path) -> subprocess.Popen[str]:
    """The sweep in a subprocess, once its first three rows are on disk."""
    proc = _sweep_process(out)
    _wait_for_rows(proc, out, 3)
    return proc


def _assert_resumes(out: Path, uninterrupted: object, capsys: pytest.CaptureFixture[str]) -> None:
    """Running the sweep again computes exactly the designs not on disk and gives the table
    of an uninterrupted run."""
    written = read_study(out).num_rows
    assert 3 <= written < N_DESIGNS  # stopped midway
    assert main([*SWEEP, "--workers", "2", "--out", str(out)]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["skipped"] == written
    assert summary["computed"] == N_DESIGNS - written  # no written design computed again
    assert read_study(out, timing=False).equals(uninterrupted)


def test_a_killed_sweep_resumes_and_computes_only_what_is_missing(
    tmp_path: Path, uninterrupted: object, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "study.parquet"
    proc = _started_sweep(out)
    os.killpg(proc.pid, signal.SIGKILL)  # the sweep and its workers, nothing written after
    proc.communicate()
    _assert_resumes(out, uninterrupted, capsys)


def test_a_terminated_sweep_writes_what_was_running_and_resumes(
    tmp_path: Path, uninterrupted: object, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "study.parquet"
    proc = _started_sweep(out)
    proc.send_signal(signal.SIGTERM)
    _, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, stderr
    assert "run the same command again to resume" in stderr
    _assert_resumes(out, uninterrupted, capsys)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--face", "X,,V"], "--face: 'X,,V' is not a comma list of X, V and S"),
        (["--rp", "1;2"], "--rp: '1;2' is not a comma list of numbers"),
        (["--h-over-d", "nan"], "--h-over-d: 'nan' is not a comma list of numbers"),
        (["--friction", ""], "--friction: '' is not a comma list of numbers"),
        (["--rp", "1,1"], "r_p lists a value twice"),
        (["--grid", "999999"], "--grid must be <= 1001"),
        (["--workers", "-3"], "workers must be in"),
        (["--damping-ratio", "0"], "damping_ratio must be in"),
        (["--scheduler", "localhost"], "--scheduler must be an address like tcp://HOST:8786"),
        (["--sigma-x", "0.1"], "--sigma-x and --sigma-theta go together: give both"),
        (["--sigma-x", "0.1", "--sigma-theta", "-1"], "sigma_theta must be in"),
    ],
)
def test_bad_sweep_input_is_one_line_and_exit_code_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str], message: str
) -> None:
    out = tmp_path / "s.parquet"
    assert main(["sweep", "--grid", "5", "--out", str(out), *argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("xface: error: ")
    assert message in err
    assert err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


def test_an_unwritable_out_is_a_clear_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sweep", "--grid", "5", "--out", "/nonexistent-folder/s.parquet"]) == 2
    assert capsys.readouterr().err.startswith("xface: error: cannot write the study to ")


def test_resuming_into_another_study_s_file_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = str(tmp_path / "s.parquet")
    assert main(["sweep", "--grid", "5", "--out", out, "--quiet"]) == 0
    assert main(["sweep", "--grid", "7", "--out", out, "--quiet"]) == 2
    assert "belongs to another study (grid 5 there, 7 here)" in capsys.readouterr().err


#: A tiny sweep: four designs on a 5 x 5 pose grid, in this process.
TINY = ["sweep", "--face", "X,V", "--h-over-d", "0.25", "--rp", "1,2", "--grid", "5"]
TINY += ["--workers", "1", "--quiet", "--json"]


def test_a_damaged_part_is_one_warning_line_and_the_sweep_completes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "s.parquet"
    with mock.patch.object(StudyFile, "compact", return_value=None):
        assert main([*TINY, "--out", str(out)]) == 0  # as if killed before folding its parts
    part = sorted(out.with_name(out.name + ".parts").iterdir())[0]
    part.write_bytes(part.read_bytes()[:50])
    capsys.readouterr()
    assert main([*TINY, "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["computed"] == 1
    (line,) = captured.err.splitlines()
    assert line.startswith(f"xface: warning: {part}: not a readable Parquet file")
    assert "moved it to" in line


def test_resuming_rows_of_another_version_is_one_line_unless_the_mix_is_allowed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "s.parquet"
    other = {"xface": "0.0.9", "engine": "0" * 64}
    with mock.patch("xface_core.study.table.writer_version", return_value=other):
        assert main(["sweep", "--grid", "5", "--out", str(out), "--quiet"]) == 0
    capsys.readouterr()
    argv = [*TINY, "--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("xface: error: ")
    assert err.count("\n") == 1
    assert "xface 0.0.9 (engine 000000000000)" in err
    assert "--allow-version-mix" in err
    assert main([*argv, "--allow-version-mix"]) == 0
    assert json.loads(capsys.readouterr().out)["computed"] == 3


def test_the_parquet_has_the_columns_the_issue_names(tmp_path: Path) -> None:
    out = tmp_path / "s.parquet"
    argv = ["sweep", "--face", "X,V", "--h-over-d", "0.25,0.5", "--rp", "1,2"]
    assert main([*argv, "--friction", "0,0.2", "--grid", "5", "--out", str(out), "--quiet"]) == 0
    table = read_study(out)
    assert {"face", "h_over_d", "r_p", "friction", "damping_ratio", "M"} <= set(table.column_names)
    assert table.num_rows == 16


def test_xface_design_reproduces_the_best_cell_of_the_table(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # On the documented smaller pose grid (11 x 11, see test_designsearch.py); the full
    # 41 x 41 check was run by hand (docs/study.md).
    png = tmp_path / "heat.png"
    argv = ["design", "--face", "X", "--refine", "0", "--grid", "11", "--workers", "1"]
    assert main([*argv, "--json", "--quiet", "--png", str(png)]) == 0
    found = json.loads(capsys.readouterr().out)
    table = xf.m_table("X", grid=11, workers=1)
    i, j = np.unravel_index(int(np.argmax(table.M)), table.M.shape)
    assert (found["best"]["h_over_d"], found["best"]["r_p"]) == (table.h_over_d[i], table.r_p[j])
    assert found["best"]["M"] == table.M.max()
    assert found["coarse"]["M"] == table.M.tolist()
    assert Image.open(png).size[0] > 11 * 40


def test_xface_design_prints_the_best_and_the_runners_up(
    capsys: pytest.CaptureFixture[str],
) -> None:
    argv = ["design", "--face", "V", "--h-over-d", "0.25,1", "--rp", "0,2", "--steps", "3"]
    assert main([*argv, "--grid", "7", "--workers", "1", "--top", "3", "--quiet"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[1].startswith("best ")
    assert lines[2].startswith("coarse best ")
    assert [ln.split()[0] for ln in lines[3:-1]] == ["2.", "3.", "4."]


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--h-over-d", "0.25"], "--h-over-d: give the box as LO,HI"),
        (["--rp", "3,1"], "the r_p box must be two finite values lo < hi"),
        (["--steps", "500"], "steps must be in"),
        (["--criterion", "seat_probability"], "the seat_probability criterion needs a pose noise"),
    ],
)
def test_bad_design_input_is_one_line_and_exit_code_2(
    capsys: pytest.CaptureFixture[str], argv: list[str], message: str
) -> None:
    assert main(["design", "--grid", "5", "--workers", "1", *argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("xface: error: ")
    assert message in err


def test_no_progress_bar_when_stderr_is_not_a_terminal(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["sweep", "--grid", "5", "--out", str(tmp_path / "s.parquet")]) == 0
    assert capsys.readouterr().err == ""


def test_the_progress_bar_counts_designs_done_and_skipped() -> None:
    stream = io.StringIO()
    bar = ProgressBar(stream, "sweep")
    bar(StudyProgress(done=0, total=4, skipped=2, elapsed=0.0))
    bar(StudyProgress(done=1, total=4, skipped=2, elapsed=2.0))
    bar.close()
    last = stream.getvalue().split("\r")[-1]
    assert "[#######.......................] 1/4 designs (2 already done)" in last
    assert "about 6 s left" in last
    assert stream.getvalue().endswith("\n")


# --- face files in sweep and design -------------------------------------------------------------


def test_xface_design_says_where_the_simulation_departs_from_the_paper(
    capsys: pytest.CaptureFixture[str],
) -> None:
    argv = ["design", "--face", "X", "--steps", "2", "--refine", "0", "--grid", "5"]
    assert main([*argv, "--workers", "1", "--quiet"]) == 0
    last = capsys.readouterr().out.splitlines()[-1]
    assert "departs from the paper" in last
    assert "docs/paper.md" in last


def _face_files(tmp_path: Path) -> tuple[str, str]:
    """Two face files both named "trap": an X-Face at D = 0.05 and a taller one at D = 1."""
    one, two = tmp_path / "trap.yaml", tmp_path / "other" / "trap.yaml"
    two.parent.mkdir()
    xf.save_face(xf.x_face(0.25, 2.0, width=0.05), one, name="trap")
    xf.save_face(xf.x_face(1.0, 2.0), two, name="trap")
    return str(one), str(two)


def test_sweep_takes_face_files_as_fixed_designs_named_by_their_name(tmp_path: Path) -> None:
    one, two = _face_files(tmp_path)
    out = tmp_path / "s.parquet"
    argv = ["sweep", "--face-file", f"{one},{two}", "--friction", "0,0.2", "--h-over-d", "1,2"]
    assert main([*argv, "--grid", "5", "--workers", "1", "--out", str(out), "--quiet"]) == 0
    rows = read_study(out).to_pylist()
    # One row per file and friction; --h-over-d does not apply to a file.
    assert len(rows) == 4
    assert {r["face"] for r in rows} == {"trap"}
    assert len({r["face_digest"] for r in rows}) == 2
    assert all(r["h_over_d"] is None and r["r_p"] is None for r in rows)
    # The X-Face H/D 0.25 r_p 2 through a file: the built-in face's M (the study runs in D).
    built_in = tmp_path / "x.parquet"
    argv = ["sweep", "--face", "X", "--h-over-d", "0.25", "--rp", "2", "--grid", "5"]
    assert main([*argv, "--workers", "1", "--out", str(built_in), "--quiet"]) == 0
    m_built_in = read_study(built_in)["M"].to_pylist()[0]
    from xface_core.study.space import face_digest

    digest = face_digest(xf.load_face(one))
    assert [r["M"] for r in rows if r["face_digest"] == digest and r["friction"] == 0.0] == [
        m_built_in
    ]


def test_design_ranks_face_files_by_the_criterion(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    one, two = _face_files(tmp_path)
    argv = ["design", "--face-file", f"{one},{two}", "--grid", "5", "--workers", "1", "--quiet"]
    assert main([*argv, "--json"]) == 0
    ranked = json.loads(capsys.readouterr().out)["face_files"]
    assert [r["face"] for r in ranked] == ["trap", "trap"]
    assert ranked[0]["M"] >= ranked[1]["M"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "do not apply to a file" in text
    assert f"trap ({ranked[0]['face_digest']})" in text


def test_a_bad_face_file_in_a_sweep_is_one_line_and_exit_code_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("xface_face: 1\n")
    out = tmp_path / "s.parquet"
    assert main(["sweep", "--face-file", str(bad), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("xface: error: the face file")
    assert err.count("\n") == 1
    assert not out.exists()
