"""``xface crosscheck``: the summary, --json, and the message without the extra."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from xface_core.cli import main

ROOT = Path(__file__).resolve().parents[3]
ARGS = ["crosscheck", "--face", "X", "--h-over-d", "0.25", "--rp", "2", "--quiet"]


def test_three_random_cells_print_the_summary(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([*ARGS, "--cells", "3", "--seed", "4"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("crosscheck X-Face H/D=0.25 r_p=2 (damping ratio 1, friction 0): 3 cells")
    for label in ("agreement ", "ambiguous ", "false SEATED ", "false failures "):
        assert label in out


def test_json_report(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([*ARGS, "--cells", "2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["cells"] == 2
    assert out["unambiguous"] + out["ambiguous"] == 2
    assert {"agreement", "false_seated", "false_failures", "disagreements", "engine"} <= set(out)
    assert len(out["xface_outcomes"]) == len(out["engine_outcomes"]) == 2


@pytest.mark.parametrize(
    "argv",
    [["--cells", "0"], ["--grid", "1"], ["--friction", "-1"], ["--step", "0"],
     ["--converge-by", "cells"]],
)  # fmt: skip
def test_bad_arguments_exit_2(argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    assert main([*ARGS, *argv]) == 2
    assert capsys.readouterr().err.startswith("xface: error: ")


def test_without_the_extra_it_says_what_to_install(tmp_path: Path) -> None:
    # A fresh interpreter in which pymunk cannot be imported, as after `pip install .`.
    code = textwrap.dedent(
        """
        import sys

        class BlockPymunk:
            def find_spec(self, name, path=None, target=None):
                if name.partition(".")[0] == "pymunk":
                    raise ModuleNotFoundError(f"No module named {name!r}", name=name)

        sys.meta_path.insert(0, BlockPymunk())
        from xface_core.cli import main

        sys.exit(main(sys.argv[1:]))
        """
    )
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])),
    }
    result = subprocess.run(
        [sys.executable, "-c", code, *ARGS, "--cells", "3"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert result.returncode == 2, result.stderr
    assert result.stderr == (
        "xface: crosscheck needs the crosscheck extra: "
        "pip install '.[crosscheck]' in the xface checkout\n"
    )
    assert result.stdout == ""


def test_the_json_says_how_the_step_was_converged(capsys: pytest.CaptureFixture[str]) -> None:
    argv = [*ARGS, "--cells", "1", "--converged", "--converge-by", "cells", "--json"]
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["converge_by"] == "cells"
    assert out["converged"] in (True, False)
