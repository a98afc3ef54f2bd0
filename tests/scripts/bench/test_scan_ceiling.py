"""scripts/bench/scan_ceiling.py edits a copy of the engine into an oracle scan: its edits must
keep applying to the engine as it is (the run itself builds the engine: minutes, not run
here)."""

from __future__ import annotations

import py_compile
import re
import runpy
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from xface_core._engine.pairs import PAIR_COLUMNS

ROOT = Path(__file__).resolve().parents[3]


def _script() -> dict[str, Any]:
    """The script's names (runpy: the script is not a module of a package)."""
    return runpy.run_path(str(ROOT / "scripts" / "bench" / "scan_ceiling.py"))


def _apply_oracle(tree: Path, *, no_turn_cap: bool = False, why_awake: bool = False) -> None:
    _script()["apply_oracle"](tree, no_turn_cap=no_turn_cap, why_awake=why_awake)


def _copy(tmp_path: Path) -> Path:
    shutil.copytree(ROOT / "xface_core", tmp_path / "xface_core", ignore=shutil.ignore_patterns(
        "__pycache__", "_compiled"))  # fmt: skip
    return tmp_path


@pytest.mark.parametrize(
    ("no_turn_cap", "why_awake"), [(False, False), (True, False), (False, True)]
)
def test_the_edits_apply_to_the_engine_and_compile(
    tmp_path: Path, no_turn_cap: bool, why_awake: bool
) -> None:
    tree = _copy(tmp_path)
    _apply_oracle(tree, no_turn_cap=no_turn_cap, why_awake=why_awake)
    engine = tree / "xface_core" / "_engine"
    edited = [*engine.glob("*.py"), tree / "xface_core" / "contact.py"]
    for path in edited:
        py_compile.compile(str(path), doraise=True)
    # Every name the edits use is defined where they put it (numba would stop the build).
    undefined = subprocess.run(
        [
            sys.executable,
            "-m",
            "ruff",
            "check",
            "--isolated",
            "--select",
            "F821",
            *map(str, edited),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert undefined.returncode == 0, undefined.stdout
    assert "def simulate_many_oracle(" in (engine / "simulate.py").read_text()
    assert ("MAX_TURN = 3.0" in (engine / "records.py").read_text()) is no_turn_cap
    widened = PAIR_COLUMNS + (8 if why_awake else 2)
    assert re.search(rf"^PAIR_COLUMNS = {widened}\b", (engine / "pairs.py").read_text(), re.M)


def test_an_edit_whose_text_is_gone_is_named(tmp_path: Path) -> None:
    tree = _copy(tmp_path)
    segment = tree / "xface_core" / "_engine" / "segment.py"
    segment.write_text(segment.read_text().replace("    elif kind == E_CONTACT:\n", "\n"))
    with pytest.raises(ValueError, match=r"_engine/segment\.py: the text to edit is found 0 times"):
        _apply_oracle(tree)


@pytest.mark.parametrize("why_awake", [False, True])
def test_the_driver_gets_the_copys_columns(tmp_path: Path, why_awake: bool) -> None:
    # As the script runs: the columns are those apply_oracle read before it widened the table.
    tree = _copy(tmp_path)
    namespace = _script()
    cols = namespace["apply_oracle"](tree, why_awake=why_awake)
    assert cols["@O@"] == str(PAIR_COLUMNS)
    for text in (namespace["DRIVER"], namespace["ORACLE_ENTRY"]):
        filled = namespace["with_columns"](text, cols)
        assert "@" not in filled.replace("@njit_cached", "")
        compile(filled, "<filled>", "exec")
