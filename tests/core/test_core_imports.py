"""The simulator without its presentation: ``xface_core`` and its command line import and
simulate in a Python where rerun and pillow (the ``viz`` extra) and ROS cannot be imported,
and the options that record or draw say what to install instead of failing with a traceback.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

#: Top-level modules of the viz extra (rerun-sdk brings rerun_bindings), of the crosscheck
#: extra (pymunk), of the study and cluster extras (pyarrow, dask), of the cad extra (ezdxf)
#: and of ROS.
BLOCKED = (
    "rerun", "rerun_bindings", "PIL", "rclpy", "pymunk", "pyarrow", "dask", "distributed",
    "ezdxf",
)  # fmt: skip

# A fresh interpreter with a meta-path finder that refuses the blocked modules, so imports
# behave as in an environment where `pip install .` installed the simulator alone.
_BLOCKER = textwrap.dedent(
    f"""
    import sys

    BLOCKED = {BLOCKED!r}

    class BlockExtras:
        def find_spec(self, name, path=None, target=None):
            if name.partition(".")[0] in BLOCKED:
                raise ModuleNotFoundError(f"No module named {{name!r}} (blocked)", name=name)
            return None

    sys.meta_path.insert(0, BlockExtras())
    """
)

_SIMULATE = textwrap.dedent(
    """
    import xface_core
    import xface_core.cli
    import xface_core.viz

    design = xface_core.x_face(0.25, 2.0)
    print(xface_core.predict(design, 0.3, 0.2).outcome.name)
    print(xface_core.acceptance_map(design, grid=11).M)
    print(sorted({m.partition(".")[0] for m in sys.modules} & set(BLOCKED)))
    print(xface_core.__file__)
    """
)

_CLI = textwrap.dedent(
    """
    from xface_core.cli import main

    sys.exit(main(sys.argv[1:]))
    """
)


def run_blocked(code: str, *args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess[str]:
    """Run ``code`` after the blocker in a new interpreter, with ``args`` as sys.argv[1:];
    it imports the xface_core of this checkout whatever ``cwd`` is."""
    path = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)
    return subprocess.run(
        [sys.executable, "-c", _BLOCKER + code, *args],
        cwd=cwd,
        env={**os.environ, "PYTHONPATH": path},
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )


@pytest.mark.parametrize("module", ["rerun", "PIL", "rclpy", "ezdxf"])
def test_blocker_makes_the_extras_unimportable(module: str) -> None:
    # Guards the tests below: without this they would pass with a blocker that blocks nothing.
    result = run_blocked(f"import {module}")
    assert result.returncode != 0
    assert "(blocked)" in result.stderr


def test_core_imports_and_simulates_without_the_extras() -> None:
    result = run_blocked(_SIMULATE)
    assert result.returncode == 0, result.stderr
    outcome, m, loaded, location = result.stdout.splitlines()
    assert outcome == "SEATED"
    assert int(m) > 0
    assert loaded == "[]"
    assert Path(location).parent == ROOT / "xface_core"


@pytest.mark.parametrize(
    ("argv", "option"),
    [
        (["map", "--face", "V", "--grid", "11", "--png", "out.png"], "--png"),
        (["design", "--grid", "5", "--steps", "2", "--png", "out.png"], "--png"),
        (["map", "--face", "V", "--grid", "11", "--rrd", "out.rrd"], "--rrd"),
        (["predict", "--x0", "0.3", "--theta0", "0.2", "--rrd", "out.rrd"], "--rrd"),
        (["bench", "--quick", "--out", "bench"], "bench"),
        (["draw", "--face", "V", "--svg", "out.svg"], "--svg"),
    ],
)
def test_cli_option_without_the_viz_extra_exits_2_with_one_line(
    tmp_path: Path, argv: list[str], option: str
) -> None:
    result = run_blocked(_CLI, *argv, cwd=tmp_path)
    assert result.returncode == 2, result.stderr
    assert (
        result.stderr
        == f"xface: {option} needs the viz extra: pip install '.[viz]' in the xface checkout\n"
    )
    assert result.stdout == ""
    assert list(tmp_path.iterdir()) == []  # refused before simulating or writing anything


def test_draw_dxf_without_the_cad_extra_exits_2_with_one_line(tmp_path: Path) -> None:
    result = run_blocked(_CLI, "draw", "--dxf", "out.dxf", cwd=tmp_path)
    assert result.returncode == 2, result.stderr
    assert result.stderr == (
        "xface: --dxf needs the cad extra: pip install '.[cad]' in the xface checkout\n"
    )
    assert list(tmp_path.iterdir()) == []


def test_a_sweep_without_the_study_extra_exits_2_with_one_line(tmp_path: Path) -> None:
    result = run_blocked(_CLI, "sweep", "--grid", "5", "--out", "s.parquet", cwd=tmp_path)
    assert result.returncode == 2, result.stderr
    assert result.stderr == (
        "xface: error: design studies need the study extra (pyarrow): "
        "pip install '.[study]' in the xface checkout\n"
    )
    assert list(tmp_path.iterdir()) == []


def test_a_scheduler_without_the_cluster_extra_exits_2_with_one_line(tmp_path: Path) -> None:
    argv = ("sweep", "--grid", "5", "--out", "s.parquet", "--scheduler", "tcp://127.0.0.1:8786")
    result = run_blocked(_CLI, *argv, cwd=tmp_path)
    assert result.returncode == 2, result.stderr
    assert result.stderr == (
        "xface: error: --scheduler needs the cluster extra: "
        "pip install '.[cluster]' in the xface checkout\n"
    )
    assert list(tmp_path.iterdir()) == []
