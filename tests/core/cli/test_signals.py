"""The xface command line at its edges (issue 35): Ctrl-C ends a run with one line and exit
code 130, leaving no half-written file behind; a closed or vanished stdout or stderr ends it
without a traceback (exit 2 for a closed stdout, 141 for a reader gone, answered as usual with
stderr closed); ``--version`` says the version and whether the first simulation compiles."""

from __future__ import annotations

import contextlib
import importlib.metadata
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

import xface_core.runner as runner
from xface_core.cli import main

ROOT = Path(__file__).resolve().parents[3]

#: Runs the command after it with SIGINT at its default disposition: a suite started from a
#: background job of a shell without job control inherits SIGINT ignored, and so would the
#: child, which then never sees the Ctrl-C these tests send.
_RESET_SIGINT = "import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_DFL); "
DEFAULT_SIGINT = [sys.executable, "-c", _RESET_SIGINT + "os.execvp(sys.argv[1], sys.argv[1:])"]

XFACE = [sys.executable, "-m", "xface_core.cli"]

#: How long a child may take to reach the state a test waits for: a cold numba cache makes the
#: first simulation compile the engine first (up to two minutes on two cores).
START_TIMEOUT_S = 300.0


def _env() -> dict[str, str]:
    """The tests' environment, importing the xface_core of this checkout."""
    path = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)
    return {**os.environ, "PYTHONPATH": path}


def _start(*args: str) -> subprocess.Popen[str]:
    """``xface args`` in a session of its own (so Ctrl-C can reach its whole group, as a
    terminal's does), SIGINT at its default whatever this process inherited."""
    return subprocess.Popen(
        [*DEFAULT_SIGINT, *XFACE, *args],
        cwd=ROOT,
        env=_env(),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )


def _wait_until(proc: subprocess.Popen[str], ready: Callable[[int], bool]) -> None:
    deadline = time.monotonic() + START_TIMEOUT_S
    while not ready(proc.pid):
        assert proc.poll() is None, f"the command ended (exit {proc.returncode}) before that"
        assert time.monotonic() < deadline, "the command never got to work"
        time.sleep(0.05)


def _children(pid: int) -> list[str]:
    tasks = Path(f"/proc/{pid}/task")
    found: list[str] = []
    for task in tasks.glob("*"):
        try:
            found += (task / "children").read_text().split()
        except OSError:
            continue  # a thread that ended meanwhile
    return found


def _cpu_s(pid: int) -> float:
    """CPU seconds ``pid`` used so far, all its threads."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _ctrl_c(args: list[str], ready: Callable[[int], bool]) -> tuple[int, str]:
    """``xface args`` (:func:`_start`) and, once ``ready(pid)``, Ctrl-C to its process group:
    its exit code and stderr. A run that does not get there, or does not end with its group
    (a worker left waiting keeps the pipes open), is killed with its group: a failure
    leaves nothing running."""
    proc = _start(*args)
    ended = False
    try:
        _wait_until(proc, ready)
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=120)
        ended = True
    finally:
        if not ended:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)
            print(proc.communicate())  # shown with the failure
    return proc.returncode, err


def _assert_interrupted(code: int, err: str) -> None:
    assert "Traceback" not in err, err
    assert err.splitlines() == ["xface: interrupted"]
    assert code == 130


def test_ctrl_c_in_a_table_is_one_line_and_exit_130() -> None:
    # As its pool's first worker appears: its pool starts, then works on the maps.
    table = ["table", "--face", "all", "--workers", "2"]
    _assert_interrupted(*_ctrl_c(table, lambda pid: bool(_children(pid))))


def test_ctrl_c_in_a_large_map_is_one_line_and_exit_130() -> None:
    # A 1001 x 1001 map takes about 20 s of CPU here: 2 s in, it is busy with the map (or,
    # with a cold cache, compiling the engine, which must end the same way).
    large_map = ["map", "--grid", "1001", "--json"]
    _assert_interrupted(*_ctrl_c(large_map, lambda pid: _cpu_s(pid) >= 2.0))


def _interrupting(real: Callable[..., Any]) -> Callable[..., Any]:
    """``real``, followed by Ctrl-C: what it wrote is there, what came after it is not."""

    def interrupted(*args: Any, **kwargs: Any) -> Any:
        real(*args, **kwargs)
        raise KeyboardInterrupt

    return interrupted


def _half_a_picture(self: Any, fname: Any, *args: Any, **kwargs: Any) -> None:
    """Figure.savefig interrupted halfway: the first bytes of a PNG, then Ctrl-C."""
    Path(fname).write_bytes(b"\x89PNG\r\n\x1a\n half")
    raise KeyboardInterrupt


def _exit_code(argv: list[str]) -> int | str:
    """``main(argv)``, with a KeyboardInterrupt that escapes it as a result (it would
    otherwise stop the whole test session)."""
    try:
        return main(argv)
    except KeyboardInterrupt:
        return "KeyboardInterrupt escaped"


def _run_interrupted(
    argv: list[str], capsys: pytest.CaptureFixture[str], expected_err: str = "xface: interrupted"
) -> None:
    assert _exit_code(argv) == 130
    assert capsys.readouterr().err.splitlines() == [expected_err]


@pytest.mark.parametrize(
    "argv",
    [
        ["map", "--grid", "5", "--png"],
        ["map", "--grid", "5", "--svg"],
        ["compare", "--grid", "5", "--vs-face", "V", "--png"],
        ["design", "--steps", "2", "--refine", "0", "--grid", "5", "--workers", "1", "--png"],
    ],
    ids=["map-png", "map-svg", "compare-png", "design-png"],
)
def test_an_interrupted_picture_leaves_no_partial_file(
    argv: list[str],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    from matplotlib.figure import Figure

    monkeypatch.setattr(Figure, "savefig", _half_a_picture)
    suffix = ".svg" if "--svg" in argv else ".png"
    _run_interrupted([*argv, str(tmp_path / f"picture{suffix}")], capsys)
    assert list(tmp_path.iterdir()) == []


def test_an_interrupted_picture_keeps_the_previous_one(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from matplotlib.figure import Figure

    picture = tmp_path / "map.png"
    picture.write_bytes(b"the last run's whole picture")
    monkeypatch.setattr(Figure, "savefig", _half_a_picture)
    _run_interrupted(["map", "--grid", "5", "--png", str(picture)], capsys)
    assert picture.read_bytes() == b"the last run's whole picture"
    assert list(tmp_path.iterdir()) == [picture]


@pytest.mark.parametrize(
    ("argv", "logger"),
    [
        (["predict", "--x0", "0.1", "--theta0", "0.1", "--no-margins"], "log_prediction"),
        (["map", "--grid", "5"], "log_acceptance_map"),
    ],
    ids=["predict", "map"],
)
def test_an_interrupted_recording_leaves_no_partial_file(
    argv: list[str],
    logger: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    import xface_core.viz.recording as recording

    # Ctrl-C after the data went to the recording, before its footer: rerun would finish
    # such a file at exit, whole-looking but cut short.
    monkeypatch.setattr(recording, logger, _interrupting(getattr(recording, logger)))
    _run_interrupted([*argv, "--rrd", str(tmp_path / "run.rrd")], capsys)
    assert list(tmp_path.iterdir()) == []


def test_an_interrupted_bench_leaves_no_partial_plot(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from matplotlib.figure import Figure

    import xface_core.cli.bench as bench
    from xface_core.viz.benchplot import read_work_precision_csv

    rows = read_work_precision_csv(ROOT / "docs" / "bench" / "work_precision.csv")
    monkeypatch.setattr(bench, "_work_precision", lambda *args: rows)  # the measured table
    monkeypatch.setattr(Figure, "savefig", _half_a_picture)
    out = tmp_path / "bench"
    _run_interrupted(["bench", "--quick", "--quiet", "--out", str(out)], capsys)
    # The tables written before the plot are whole; the plot is not there.
    assert sorted(p.name for p in out.iterdir()) == ["work_precision.csv", "work_precision.md"]


def test_an_interrupted_design_without_out_does_not_offer_to_resume(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import xface_core.cli.study as cli_study

    def interrupted(*args: Any, **kwargs: Any) -> Any:
        raise KeyboardInterrupt

    # Without --out the study lives in a temporary folder, removed: nothing to resume.
    monkeypatch.setattr(cli_study, "search_designs", interrupted)
    _run_interrupted(["design", "--steps", "2", "--refine", "0", "--grid", "5"], capsys)


def _run_in_shell(redirect: str, *args: str) -> subprocess.CompletedProcess[str]:
    """``xface args`` started by a shell with ``redirect`` (``>&-``: stdout closed)."""
    return subprocess.run(
        ["bash", "-c", f'exec "$@" {redirect}', "bash", *XFACE, *args],
        cwd=ROOT,
        env=_env(),
        capture_output=True,
        text=True,
        timeout=START_TIMEOUT_S,
        check=False,
    )


PREDICT = ["predict", "--x0", "0.1", "--theta0", "0.1", "--no-margins"]


def test_a_closed_stdout_is_one_error_line_and_exit_2() -> None:
    proc = _run_in_shell(">&-", *PREDICT)
    said = "xface: error: stdout is closed: nowhere to write the answer"
    assert proc.stderr.splitlines() == [said]
    assert proc.returncode == 2


def test_a_closed_stderr_still_answers_on_stdout() -> None:
    proc = _run_in_shell("2>&-", *PREDICT)
    assert any(line.startswith("outcome ") for line in proc.stdout.splitlines()), proc.stdout
    assert proc.returncode == 0


def test_a_reader_gone_before_the_help_is_written_ends_quietly_with_141() -> None:
    # Buffered, as a user's stdout is: unbuffered, argparse's own write meets the dead pipe
    # and swallows the error (exit 0); buffered, the flush at exit met it (exit 120).
    env = {k: v for k, v in _env().items() if k != "PYTHONUNBUFFERED"}
    proc = subprocess.Popen(
        [*XFACE, "--help"],
        cwd=ROOT,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None
    proc.stdout.close()  # before the interpreter has even started: every write fails
    _, err = proc.communicate(timeout=START_TIMEOUT_S)
    assert err == ""
    assert proc.returncode == 141


@dataclass(frozen=True)
class _FakeEngineState:
    """runner.EngineState's contract: ``describe()`` is the text ``--version`` shows."""

    ready: bool = False
    source: str = "compiles"
    compile_estimate_s: float = 60.0

    def describe(self) -> str:
        return "compiles on first use (about 60 s)"


class _NoEngine:
    """Stands in for the engine: any use of it is a simulation ``--version`` must not run."""

    def __getattr__(self, name: str) -> Any:
        raise AssertionError(f"--version used the engine ({name})")


def test_version_prints_the_version_and_the_engine_state(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(runner, "engine_state", _FakeEngineState, raising=False)
    monkeypatch.setattr(runner, "_engine", _NoEngine())
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.splitlines() == [
        f"xface {importlib.metadata.version('xface')}",
        "engine: compiles on first use (about 60 s)",
    ]


_VERSION_ALONE = """
import sys
from xface_core.cli import main
from xface_core.runner import engine_state
code = main(["--version"])
extras = ("rerun", "matplotlib", "PIL", "pyarrow", "dask", "distributed", "pymunk", "rclpy")
print(sorted(m for m in extras if m in sys.modules))
print("engine: " + engine_state().describe())
sys.exit(code)
"""


def test_version_shows_the_real_engine_state_without_importing_an_extra() -> None:
    proc = subprocess.run(
        [sys.executable, "-c", _VERSION_ALONE],
        cwd=ROOT,
        env=_env(),
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    version, engine, extras, state = proc.stdout.splitlines()
    assert version.startswith("xface ")
    assert engine == state  # the engine's own description, looked up again afterwards
    assert extras == "[]"
