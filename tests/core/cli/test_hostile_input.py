"""The xface command line under hostile input (issue 38): never a traceback for a user error.

Negative numbers in every spelling, output names that cannot be written as asked (empty, not
UTF-8, ending in a separator, with another format's suffix), a compare without design B, a
face file whose error is many lines, and a closed stderr: each is one ``xface: error:`` line
(or nothing, with stderr closed) and exit code 2, before any simulation runs.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import xface_core.cli.commands as commands
from xface_core.cli import build_parser, main
from xface_core.errors import FaceFileError

ROOT = Path(__file__).resolve().parents[3]
XFACE = [sys.executable, "-m", "xface_core.cli"]
PREDICT = ["predict", "--x0", "0.1", "--theta0", "0.1", "--no-margins"]

#: A name with a byte that is not UTF-8 (0xff), as a POSIX shell passes it: argv decoded
#: with surrogateescape, as Python does.
NOT_UTF8 = os.fsdecode(b"study\xff.parquet")


def _one_error_line(capsys: pytest.CaptureFixture[str], argv: list[str], says: str) -> str:
    """``xface argv`` exits 2 with one ``xface: error:`` line holding ``says``; the line."""
    assert main(argv) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1, err
    assert err[0].startswith("xface: error: ")
    assert says in err[0]
    return err[0]


def _env() -> dict[str, str]:
    path = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)
    return {**os.environ, "PYTHONPATH": path}


def _run(
    argv: list[str | bytes], cwd: Path, redirect: str = ""
) -> subprocess.CompletedProcess[bytes]:
    """``xface argv`` as a program, started by a shell with ``redirect`` (``2>&-``); bytes
    argv pass as they are (a name that is not UTF-8)."""
    return subprocess.run(
        ["bash", "-c", f'exec "$@" {redirect}', "bash", *XFACE, *argv],
        cwd=cwd,
        env=_env(),
        capture_output=True,
        timeout=300,
        check=False,
    )


# --- negative numbers -----------------------------------------------------------------------


def _float_options() -> list[tuple[str, str, list[str]]]:
    """(command, option, the command's required options) for every float option of every
    subcommand: the parser's own inventory, so a new option is covered without a new test."""
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    found = []
    for command, p in sub.choices.items():
        required = [part for a in p._actions if a.required for part in (a.option_strings[0], "0.1")]
        for action in p._actions:
            if action.type is float:
                found.append((command, action.option_strings[-1], required))
    return found


@pytest.mark.parametrize(("command", "option", "required"), _float_options())
def test_every_float_option_takes_a_negative_number_in_scientific_notation(
    command: str, option: str, required: list[str]
) -> None:
    args = build_parser().parse_args([command, *required, option, "-1e-3"])
    assert getattr(args, option.removeprefix("--").replace("-", "_")) == -1e-3


@pytest.mark.parametrize("spelling", ["-1e-3", "-1E-3", "-.1e-1", "-1.e-3", "-0.001", "-1e+0"])
def test_a_negative_x0_predicts_in_any_spelling_of_the_number(
    capsys: pytest.CaptureFixture[str], spelling: str
) -> None:
    assert main(["predict", "--x0", spelling, "--theta0", "-1e-1", "--no-margins", "--json"]) == 0
    assert f'"x0": {float(spelling)!r}' in capsys.readouterr().out


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["predict", "--x0", "-inf", "--theta0", "0"], "x0 must be finite"),
        (["predict", "--x0", "0", "--theta0", "0", "--friction", "-1e-3"], "friction"),
        (["sweep", "--grid", "5", "--h-over-d", "-1e-1,0.5", "--out", "s.parquet"], "h_over_d"),
    ],
)
def test_a_negative_number_reaches_the_range_check_not_argparse(
    capsys: pytest.CaptureFixture[str], argv: list[str], says: str
) -> None:
    """Refused by the value's own check (one line), not by argparse as a missing value."""
    _one_error_line(capsys, argv, says)


# --- output names -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "argv",
    [
        ["map", "--grid", "5", "--png", "somedir/"],
        ["map", "--grid", "5", "--svg", "somedir/"],
        [*PREDICT, "--rrd", "somedir/"],
        ["sweep", "--grid", "5", "--out", "somedir/"],
    ],
)
def test_an_output_file_name_ending_in_a_separator_is_refused(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
    argv: list[str],
) -> None:  # fmt: skip
    monkeypatch.chdir(tmp_path)
    _one_error_line(capsys, argv, "'somedir/': ends in a separator")
    assert list(tmp_path.iterdir()) == []  # no file named somedir, no study folder


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["map", "--grid", "5", "--png", "out.jpg"], "--png writes a PNG picture: name it *.png"),
        (["map", "--grid", "5", "--svg", "out.txt"], "--svg writes an SVG picture"),
        (["map", "--grid", "5", "--png", "out"], "name it *.png"),
        ([*PREDICT, "--rrd", "out.png"], "--rrd writes a rerun recording: name it *.rrd"),
        (["compare", "--grid", "5", "--vs-rp", "2", "--svg", "c.png"], "name it *.svg"),
        (["design", "--steps", "2", "--refine", "0", "--grid", "5", "--png", "h.svg"], "*.png"),
    ],
)
def test_an_output_name_whose_suffix_is_not_its_format_is_refused(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
    argv: list[str], says: str,
) -> None:  # fmt: skip
    monkeypatch.chdir(tmp_path)
    _one_error_line(capsys, argv, says)
    assert list(tmp_path.iterdir()) == []


def test_an_upper_case_suffix_names_its_format(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    assert main(["map", "--grid", "5", "--png", str(tmp_path / "MAP.PNG")]) == 0
    assert (tmp_path / "MAP.PNG").read_bytes().startswith(b"\x89PNG")


@pytest.mark.parametrize("option", ["--png", "--svg", "--rrd"])
def test_an_empty_output_name_is_refused_not_ignored(
    capsys: pytest.CaptureFixture[str], option: str
) -> None:
    _one_error_line(capsys, ["map", "--grid", "5", option, ""], f"{option}: the name is empty")


@pytest.mark.parametrize(
    "argv",
    [
        ["sweep", "--grid", "5", "--workers", "1", "--out"],
        ["design", "--steps", "2", "--refine", "0", "--grid", "5", "--workers", "1", "--out"],
        ["map", "--grid", "5", "--png"],
        ["map", "--grid", "5", "--svg"],
        [*PREDICT, "--rrd"],
    ],
)
def test_an_output_name_that_is_not_utf8_is_one_line_and_exit_2(
    tmp_path: Path, argv: list[str]
) -> None:
    """A real program: the name's bytes come from the shell, not from Python."""
    suffix = {"--png": b".png", "--svg": b".svg", "--rrd": b".rrd"}.get(argv[-1], b".parquet")
    proc = _run([*argv, b"out\xff" + suffix], tmp_path)
    name = f"'out\\xff{suffix.decode()}'"
    said = f"xface: error: {argv[-1]} {name}: the name is not UTF-8 text; rename it"
    assert proc.stderr.decode().splitlines() == [said]
    assert proc.returncode == 2
    assert list(tmp_path.iterdir()) == []


def test_a_bench_folder_that_is_not_utf8_is_refused(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import xface_core.cli.bench as bench

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(bench, "run_bench", lambda args: 0)  # refused before it, or a pass
    _one_error_line(capsys, ["bench", "--quick", "--out", NOT_UTF8], "'study\\xff.parquet'")


def test_a_negative_crosscheck_seed_is_one_error_line(capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("pymunk")
    _one_error_line(capsys, ["crosscheck", "--cells", "1", "--seed", "-1"], "--seed must be >= 0")


# --- compare, face files, closed stderr ---------------------------------------------------------


def test_compare_without_a_vs_option_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    line = _one_error_line(capsys, ["compare", "--grid", "5"], "compare needs a design B")
    assert "--vs-face, --vs-h-over-d, --vs-rp, --vs-face-file" in line


def test_a_face_file_with_a_yaml_syntax_error_is_one_line(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    face = tmp_path / "bad.yaml"
    face.write_text("kind: custom\n  width: [1\nfoo: : bar\n")
    argv = ["predict", "--face-file", str(face), "--x0", "0", "--theta0", "0"]
    _one_error_line(capsys, argv, "is not valid YAML")


def test_any_face_file_error_is_one_line_whatever_its_length(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    report = "\n".join(f"  line {k} of the report\n     ^" for k in range(40))

    def load_face(path: Any) -> Any:
        raise FaceFileError(f"the face file {path!r} is bad:\n{report}\n")

    monkeypatch.setattr(commands, "load_face", load_face)
    line = _one_error_line(capsys, ["predict", "--face-file", "f.yaml", *PREDICT[1:]], "is bad:")
    lines = " ".join(f"line {k} of the report" for k in range(40))
    assert line == f"xface: error: the face file 'f.yaml' is bad: {lines}"


def test_an_error_quoting_undecodable_bytes_is_one_escaped_line(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """pytest's stderr, like a strict one, cannot encode a surrogate: escaped, not raised."""

    def load_face(path: Any) -> Any:
        raise FaceFileError(f"cannot read the face file {path}")

    monkeypatch.setattr(commands, "load_face", load_face)
    argv = ["predict", "--face-file", os.fsdecode(b"f\xff.yaml"), *PREDICT[1:]]
    _one_error_line(capsys, argv, "cannot read the face file f\\udcff.yaml")


def test_a_closed_stderr_takes_an_error_quoting_undecodable_bytes(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Python starts with sys.stderr None when descriptor 2 is closed: main's stand-in for it
    escapes what it cannot encode rather than raising (exit 1, a traceback nobody sees)."""

    def load_face(path: Any) -> Any:
        raise FaceFileError(f"cannot read the face file {path}")

    monkeypatch.setattr(commands, "load_face", load_face)
    monkeypatch.setattr(sys, "stderr", None)
    argv = ["predict", "--face-file", os.fsdecode(b"f\xff.yaml"), *PREDICT[1:]]
    assert main(argv) == 2


def test_a_closed_stderr_with_a_user_error_exits_2_with_no_traceback(tmp_path: Path) -> None:
    """``xface predict ... <bytes> 2>&-``: argparse quotes the unknown argument as it is."""
    proc = _run([*PREDICT, b"\xff"], tmp_path, redirect="2>&-")
    assert proc.stdout == b""
    assert proc.returncode == 2


def test_a_closed_stderr_with_a_non_utf8_study_name_exits_2(tmp_path: Path) -> None:
    proc = _run(["sweep", "--grid", "5", "--out", b"/nonexistent/s\xff"], tmp_path, "2>&-")
    assert (proc.returncode, proc.stdout) == (2, b"")


# --- property: any mix of options and hostile values ---------------------------------------------

#: Hostile numbers: not a number, not finite, huge, negative in several spellings; a few
#: that are no float at all (empty, a list, bytes that are not UTF-8 as argv decodes them).
NUMBERS = st.sampled_from(
    ["nan", "-nan", "inf", "-inf", "1e308", "-1e308", "1e999", "-1e-3", "-.5", "-0", "0",
     "0.3", "2", "", "-", "1,2", os.fsdecode(b"\xff")]
)  # fmt: skip
#: Hostile names: empty, a folder, separators, another format's suffix, not UTF-8, a dash.
NAMES = st.sampled_from(
    ["", " ", "/", "a/", "x.png", "x.rrd", "no/x.rrd", os.fsdecode(b"m\xff.rrd"),
     os.fsdecode(b"m\xff.png"), "-"]
)  # fmt: skip
PREDICT_OPTIONS = {
    **dict.fromkeys(
        ["--x0", "--theta0", "--y-start", "--h-over-d", "--rp", "--width", "--damping-ratio",
         "--friction"], NUMBERS
    ),
    "--face": st.sampled_from(["x", "V", "s", "Q", ""]),
    "--rrd": NAMES,
    "--face-file": NAMES,
}  # fmt: skip


@st.composite
def _predict_options(draw: st.DrawFn) -> list[tuple[str, str]]:
    """A predict's options: the pose first, mostly plain (so that most runs get past argparse
    and the pose check to the checks behind them), then hostile values for any options, a
    later one winning."""
    pose = st.one_of(st.sampled_from(["0.1", "-0.2", "-1e-2"]), NUMBERS)
    options = [("--x0", draw(pose)), ("--theta0", draw(pose))]
    for option in draw(st.lists(st.sampled_from(sorted(PREDICT_OPTIONS)), max_size=3)):
        options.append((option, draw(PREDICT_OPTIONS[option])))
    return options


def _outcome(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


@settings(max_examples=40, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(options=_predict_options())
def test_any_argument_vector_exits_0_or_2_the_same_in_both_spellings(
    options: list[tuple[str, str]], capsys: pytest.CaptureFixture[str], tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:  # fmt: skip
    """Whatever the values: exit 0 or 2, never an exception; a user error is one ``xface``
    line (argparse's: usage, then its line); only recordings named as one are written; and
    ``--x0 -1e-2`` means what ``--x0=-1e-2`` means (as for every value here)."""
    monkeypatch.chdir(tmp_path)  # a plain --rrd name is written here
    argv = ["predict", "--no-margins", *(part for pair in options for part in pair)]
    code, out, err = _outcome(argv, capsys)
    assert code in (0, 2)
    lines = err.splitlines()
    if code == 2 and not lines[0].startswith("usage:"):
        assert len(lines) == 1, lines
        assert lines[0].startswith("xface: "), lines
    assert all(p.suffix == ".rrd" for p in tmp_path.iterdir())
    joined = ["predict", "--no-margins", *(f"{option}={value}" for option, value in options)]
    assert _outcome(joined, capsys) == (code, out, err)
