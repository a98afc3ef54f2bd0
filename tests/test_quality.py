"""Architecture and isolation rules that no linter checks.

* ``xface_core`` is the pure simulator: it must import, every module of it, in a Python
  where no ROS package can be imported, and no module of it may import rclpy or a message
  package (so users who only simulate need no ROS install).
* Every test that starts rclpy runs with discovery on this host only and a domain of its own.
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]
CORE = ROOT / "xface_core"

# Top-level module names that belong to ROS 2: the client library, its C layers, the code
# generators and the message packages. Anything matching may not be imported by the core.
# xface_ros is on the list too: it is the ROS adapter, and the core must not depend on it.
_ROS_EXACT = {
    "rclpy",
    "rpyutils",
    "ament_index_python",
    "launch",
    "launch_ros",
    "tf2_ros",
    "xface_ros",
}
_ROS_PREFIXES = ("rcl", "rmw", "rosidl", "ros_", "rosgraph")
_ROS_SUFFIXES = ("_msgs", "_srvs", "_interfaces")


def is_ros_module(name: str) -> bool:
    """True if the module ``name`` (dotted) belongs to a ROS 2 package."""
    top = name.partition(".")[0]
    return top in _ROS_EXACT or top.startswith(_ROS_PREFIXES) or top.endswith(_ROS_SUFFIXES)


def ros_imports(source: str) -> list[str]:
    """The ROS modules that ``source`` imports, statically or by a literal dynamic import."""
    found = []
    for node in ast.walk(ast.parse(source)):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
        elif isinstance(node, ast.Call) and node.args:
            func = node.func
            callee = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            first = node.args[0]
            if callee in {"import_module", "__import__"} and isinstance(first, ast.Constant):
                names = [str(first.value)]
        found += [name for name in names if is_ros_module(name)]
    return found


def core_modules() -> list[str]:
    """Dotted names of the package and of every module in the xface_core source tree."""
    names = {
        ".".join(path.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")
        for path in CORE.rglob("*.py")
    }
    return sorted(names | {"xface_core"})


# Run in a fresh interpreter: a meta-path finder that refuses every ROS module, so the import
# behaves as in an environment where no ROS package is installed.
_BLOCKER = textwrap.dedent(
    """
    import importlib, sys

    PREFIXES = {prefixes!r}
    SUFFIXES = {suffixes!r}
    EXACT = {exact!r}

    class BlockRos:
        def find_spec(self, name, path=None, target=None):
            top = name.partition(".")[0]
            if top in EXACT or top.startswith(PREFIXES) or top.endswith(SUFFIXES):
                raise ModuleNotFoundError(f"No module named {{name!r}} (ROS blocked)", name=name)
            return None

    sys.meta_path.insert(0, BlockRos())
    importlib.import_module(sys.argv[1])
    """
).format(prefixes=_ROS_PREFIXES, suffixes=_ROS_SUFFIXES, exact=_ROS_EXACT)


def import_without_ros(module: str) -> subprocess.CompletedProcess[str]:
    """Import ``module`` in a new interpreter in which no ROS module can be imported."""
    return subprocess.run(
        [sys.executable, "-c", _BLOCKER, module],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )


def test_ros_detector_recognises_rclpy_and_message_imports() -> None:
    source = "import rclpy.node\nfrom geometry_msgs.msg import Pose\nimport numpy\n"
    assert ros_imports(source) == ["rclpy.node", "geometry_msgs.msg"]


def test_ros_detector_recognises_literal_dynamic_imports() -> None:
    source = "import importlib\nm = importlib.import_module('std_srvs.srv')\n"
    assert ros_imports(source) == ["std_srvs.srv"]


def test_ros_detector_ignores_relative_and_similar_names() -> None:
    source = "from . import geometry\nfrom .result import Prediction\nimport rerun, shapely\n"
    assert ros_imports(source) == []


def test_no_core_module_imports_ros() -> None:
    sources = sorted(CORE.rglob("*.py"))
    assert sources, f"no Python files found under {CORE}"
    offenders = {
        str(path.relative_to(ROOT)): found
        for path in sources
        if (found := ros_imports(path.read_text(encoding="utf-8")))
    }
    assert offenders == {}, "xface_core must not import ROS packages"


def test_blocker_makes_rclpy_unimportable() -> None:
    # Guards the tests below: without this they would pass with a blocker that blocks nothing.
    result = import_without_ros("rclpy")
    assert result.returncode != 0
    assert "ROS blocked" in result.stderr


@pytest.mark.parametrize("module", core_modules())
def test_core_module_imports_without_ros(module: str) -> None:
    result = import_without_ros(module)
    assert result.returncode == 0, result.stderr


def test_ros_discovery_is_limited_to_this_host() -> None:
    assert os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
    assert os.environ["ROS_STATIC_PEERS"] == ""


def test_ros_domain_id_fixture_sets_the_environment(ros_domain_id: int) -> None:
    assert os.environ["ROS_DOMAIN_ID"] == str(ros_domain_id)


def test_ros_domain_id_fixture_stays_in_the_test_range(ros_domain_id: int) -> None:
    assert 100 <= ros_domain_id <= 199


@pytest.mark.parametrize("locked", [False, True])
def test_consecutive_tests_get_distinct_domain_ids(
    ros_domain_allocator: Any, tmp_path: Path, locked: bool
) -> None:
    # The session's allocator class over the whole test range, its locks (if any) private to
    # this test, so that another session's held ids cannot shorten the cycle checked here.
    allocator = type(ros_domain_allocator)(
        range(100, 200), start=os.getpid(), lock_dir=tmp_path if locked else None
    )
    ids = [allocator.allocate() for _ in range(100)]
    assert len(set(ids)) == 100


def test_a_domain_id_held_by_another_session_is_passed_over(
    ros_domain_allocator: Any, tmp_path: Path
) -> None:
    allocator = type(ros_domain_allocator)  # tests/conftest.py's DomainIdAllocator
    other = allocator(range(100, 104), start=0, lock_dir=tmp_path)
    this = allocator(range(100, 104), start=0, lock_dir=tmp_path)
    assert other.allocate() == 100
    assert [this.allocate(), this.allocate()] == [101, 102]  # 100 is the other's
    this.release(101)
    other.release(100)
    assert [this.allocate(), this.allocate()] == [103, 100]  # 102 is still this one's
    third = allocator(range(100, 104), start=0, lock_dir=tmp_path)
    assert third.allocate() == 101
    with pytest.raises(RuntimeError, match="held by running test sessions"):
        allocator(range(100, 104), start=0, lock_dir=tmp_path).allocate()
