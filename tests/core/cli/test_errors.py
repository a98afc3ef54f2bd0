"""The xface command line never shows a traceback for a user error: one ``xface: error:``
line and exit code 2 (issue 14's list), and quiet on a closed pipe."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

import xface_core as xf
from xface_core.cli import main


def _error(capsys: pytest.CaptureFixture[str], argv: list[str], message: str) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith("xface: error: ")
    assert message in err[0]


@pytest.mark.parametrize("option", ["--png", "--rrd"])
def test_an_unwritable_picture_or_recording_is_an_error(
    capsys: pytest.CaptureFixture[str], option: str
) -> None:
    name = f"/nonexistent/dir/out.{option.removeprefix('--')}"
    _error(capsys, ["map", "--grid", "5", option, name], "/nonexistent")


@pytest.mark.parametrize("command", ["predict --x0 0.1 --theta0 0.1", "map --grid 5"])
def test_an_unwritable_recording_prints_one_line_and_nothing_from_rerun(
    tmp_path: Path, command: str
) -> None:
    """Run as a program: rerun's own warnings go to the process's stderr, past capsys."""
    folder = tmp_path / "taken.rrd"  # named as a recording, but a folder
    folder.mkdir()
    proc = subprocess.run(
        [sys.executable, "-m", "xface_core.cli", *command.split(), "--rrd", str(folder)],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert proc.returncode == 2
    err = proc.stderr.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith("xface: error: cannot write the recording ")


def test_an_absurd_grid_is_refused_with_an_estimate(capsys: pytest.CaptureFixture[str]) -> None:
    _error(capsys, ["map", "--grid", "100001"], "GiB of arrays; the largest grid is 1001")


@pytest.mark.parametrize("workers", ["0", "-3", "1025", "100000"])
def test_workers_must_be_in_their_range(capsys: pytest.CaptureFixture[str], workers: str) -> None:
    _error(capsys, ["table", "--face", "V", "--workers", workers], "--workers must be in [1, 1024]")


def test_bench_does_not_grow_a_tree_of_folders(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    out = tmp_path / "no" / "such" / "bench"
    _error(capsys, ["bench", "--quick", "--out", str(out)], "does not exist")
    assert not (tmp_path / "no").exists()


def test_a_missing_face_file_is_an_error(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    _error(
        capsys,
        ["predict", "--face-file", str(tmp_path / "none.yaml"), "--x0", "0", "--theta0", "0"],
        "cannot read the face file",
    )


def test_an_interpenetrating_start_exits_2_without_margins(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # Started 0.5 D lower than the mated distance, straight down: the parts overlap.
    argv = ["predict", "--rp", "2", "--x0", "0", "--theta0", "0", "--y-start", "3.75", "--json"]
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert '"outcome": "INVALID_INPUT"' in captured.out
    assert "margins" not in captured.out
    assert captured.err.startswith("xface: INVALID_INPUT: ")


def test_a_face_file_predicts_like_the_api(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    design = xf.v_face(0.5, 1.0)
    path = xf.save_face(design, tmp_path / "v.yaml")
    argv = ["predict", "--face-file", str(path), "--x0", "0.2", "--theta0", "0.3", "--json"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    expected = xf.predict(design, 0.2, 0.3)
    assert f'"outcome": "{expected.outcome.name}"' in out


def test_phases_are_printed_in_path_order(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["predict", "--rp", "2", "--x0", "0.3", "--theta0", "0.2", "--no-margins"]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("path"))
    assert line.endswith("phases: approach, align, slide, end")


def test_the_text_map_has_the_largest_x0_on_top(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["map", "--grid", "5"]) == 0
    rows = [x.strip() for x in capsys.readouterr().out.splitlines() if x.strip()[:1] in "+-"]
    assert rows[0].startswith("+1.0000")
    assert rows[-1].startswith("-1.0000")


def test_a_closed_pipe_ends_quietly() -> None:
    # ``xface map | head -1``: the reader is gone after one line.
    proc = subprocess.run(
        f"{sys.executable} -m xface_core.cli map --grid 41 | head -1",
        shell=True,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.stdout.count("\n") == 1
    assert "Traceback" not in proc.stderr
    assert "BrokenPipe" not in proc.stderr


def test_a_table_shows_a_progress_bar_on_a_terminal(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert main(["table", "--face", "V", "--workers", "1", "--json"]) == 0
    err = capsys.readouterr().err
    assert "V-Face table [" in err
    assert "121/121 designs" in err


def test_no_progress_bar_when_stderr_is_not_a_terminal(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["map", "--grid", "201", "--json"]) == 0
    assert capsys.readouterr().err == ""


def _small_bench(monkeypatch: pytest.MonkeyPatch) -> None:
    """``xface bench --quick`` on one design, each time taken once: the same steps, fewer."""
    import xface_core.cli.bench as bench

    monkeypatch.setattr(bench, "BENCH_DESIGNS", bench.BENCH_DESIGNS[:1])
    monkeypatch.setattr(bench, "_median_time", lambda fn, repeats: bench.time.perf_counter())


@pytest.mark.slow
def test_the_bench_shows_a_progress_bar_on_a_terminal(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    _small_bench(monkeypatch)
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert main(["bench", "--quick", "--out", str(tmp_path / "bench")]) == 0
    out, err = capsys.readouterr()
    assert "rtol=" in out
    assert "wrote " in out
    counts = [(int(a), int(b)) for a, b in re.findall(r"bench \[[#.]+\] (\d+)/(\d+) steps", err)]
    assert counts, err
    total = counts[-1][1]
    # Every step drawn, in order, and the last one is the whole bench.
    assert sorted({done for done, _ in counts}) == list(range(1, total + 1))
    assert {t for _, t in counts} == {total}


@pytest.mark.slow
def test_the_bench_is_quiet_with_quiet_or_off_a_terminal(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    _small_bench(monkeypatch)
    assert main(["bench", "--quick", "--out", str(tmp_path / "a")]) == 0
    assert capsys.readouterr().err == ""
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert main(["bench", "--quick", "--quiet", "--out", str(tmp_path / "b")]) == 0
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize(
    ("argv", "tty", "cached", "said"),
    [
        (["predict", "--x0", "0.1", "--theta0", "0.1", "--json"], True, False, True),
        (["predict", "--x0", "0.1", "--theta0", "0.1", "--json"], True, True, False),
        (["predict", "--x0", "0.1", "--theta0", "0.1", "--json"], False, False, False),
        (["table", "--face", "X", "--method", "bound", "--json"], True, False, False),
        (["map", "--grid", "5", "--quiet", "--json"], True, False, False),
    ],
)
def test_a_first_run_on_a_terminal_says_that_it_compiles(
    argv: list[str],
    tty: bool,
    cached: bool,
    said: bool,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import xface_core.cli.commands as cli

    monkeypatch.setattr(sys.stderr, "isatty", lambda: tty)
    monkeypatch.setattr(cli, "engine_is_cached", lambda: cached)
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert (cli.COMPILING_NOTICE in err) is said
