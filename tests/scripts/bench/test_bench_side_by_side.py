"""scripts/bench/bench_side_by_side.py: two versions of xface_core, timed side by side.

Timings are never asserted (a shared machine says nothing about them in a test); the tests
check that the script runs, writes its table and rewrites absolute imports in its copies.
"""

from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parents[3]


def _load_script() -> ModuleType:
    script = ROOT / "scripts" / "bench" / "bench_side_by_side.py"
    spec = importlib.util.spec_from_file_location("bench_side_by_side", script)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while it loads
    spec.loader.exec_module(module)
    return module


bench = _load_script()


@pytest.mark.slow
def test_quick_run_writes_a_table_with_ratios(tmp_path: Path) -> None:
    # HEAD is extracted and compiled afresh (about 20 s); the working tree uses its cache.
    out = tmp_path / "side_by_side.md"
    argv = ["--before", "HEAD", "--after", "WORKTREE", "--repeats", "1", "--quick"]
    assert bench.main([*argv, "--out", str(out)]) == 0
    text = out.read_text("utf-8")
    assert bench.HEADER in text
    assert "--before HEAD --after WORKTREE --repeats 1 --quick" in text
    rows = [line for line in text.splitlines() if line.startswith("| map X 0.25/2 11x11 |")]
    assert len(rows) == 1
    ratio = rows[0].split("|")[5]
    assert re.fullmatch(r" \d+\.\d{3} ", ratio)
    assert "identical outcomes: map X 0.25/2 11x11 (poses 121," in text  # every cell compared
    assert "identical M: table X, one design, 11x11, 1 worker (1 designs)" in text
    assert any(line.startswith("| every table (geometric mean) |") for line in text.splitlines())
    assert "xface_core_before" not in sys.modules  # the copy is unloaded


def test_absolute_references_are_rewritten_relative_ones_kept(tmp_path: Path) -> None:
    package = tmp_path / "xface_core_before"
    package.mkdir()
    (package / "paper.py").write_text(
        "from importlib import resources\n"
        "import xface_core.kernel as K\n"
        "from xface_core import x_face\n"
        "from .kernel import simulate\n"
        'DATA = resources.files("xface_core.data")\n'
        "xface_core_like = 1\n",
        "utf-8",
    )
    assert bench.rewrite_absolute(package, "xface_core_before") == 3
    assert (package / "paper.py").read_text("utf-8") == (
        "from importlib import resources\n"
        "import xface_core_before.kernel as K\n"
        "from xface_core_before import x_face\n"
        "from .kernel import simulate\n"
        'DATA = resources.files("xface_core_before.data")\n'
        "xface_core_like = 1\n"
    )


def test_a_bad_revision_exits_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert bench.main(["--before", "no-such-revision-xyz", "--quick", "--repeats", "1"]) == 2
    assert "error:" in capsys.readouterr().err


def test_repeats_must_be_positive() -> None:
    with pytest.raises(SystemExit):
        bench.parse(["--before", "HEAD", "--repeats", "0"])


def test_only_keeps_the_kinds_named_and_refuses_others() -> None:
    assert bench.parse(["--before", "HEAD", "--only", "table, map"]).only == ["table", "map"]
    assert bench.parse(["--before", "HEAD"]).only == list(bench.KINDS)
    with pytest.raises(SystemExit):
        bench.parse(["--before", "HEAD", "--only", "maps"])


def test_cpu_is_host_by_default_generic_on_request_and_nothing_else() -> None:
    assert bench.parse(["--before", "HEAD"]).cpu == "host"
    assert bench.parse(["--before", "HEAD", "--cpu", "generic"]).cpu == "generic"
    with pytest.raises(SystemExit):
        bench.parse(["--before", "HEAD", "--cpu", "skylake"])


@pytest.mark.parametrize("cpu", ["host", "generic"])
def test_the_serving_processes_compile_for_the_cpu_asked(tmp_path: Path, cpu: str) -> None:
    # Both copies' processes report the CPU numba compiles for (the shipped build's generic
    # codegen, or this machine's); nothing is compiled to answer.
    args = bench.parse(["--before", "HEAD", "--after", "WORKTREE", "--cpu", cpu])
    args.before = "WORKTREE"
    sides, _ = bench.start_sides(args, tmp_path)
    try:
        assert [side.ask("hello")["cpu"] for side in sides] == [cpu, cpu]
    finally:
        for side in sides:
            side.close()
