"""A parameter file the node cannot use is a user error: one line on stderr, exit code 2.

rcl refuses a missing file or broken YAML with a traceback (exit code 1) and runs without a
word on a file that is YAML but sets nothing; the node checks its ``--params-file`` arguments
before rclpy starts. Both ways of starting it are tested: ``python -m xface_ros`` and the
``xface-predictor`` command the install puts beside the interpreter.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from xface_ros.node import params_layout_problem

pytestmark = pytest.mark.ros

LAUNCHERS = {
    "python -m xface_ros": [sys.executable, "-m", "xface_ros"],
    "xface-predictor": [str(Path(sys.executable).with_name("xface-predictor"))],
}


def run_node(launcher: str, params_file: str, cwd: Path, env: dict[str, str]) -> tuple[int, str]:
    """Start the node on ``params_file``; its exit code and stderr (it must not start)."""
    run = subprocess.run(
        [*LAUNCHERS[launcher], "--ros-args", "--params-file", params_file],
        cwd=cwd, env=env, capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    return run.returncode, run.stderr


@pytest.fixture
def node_env(ros_domain_id: int) -> dict[str, str]:
    """The environment of a node process: loopback discovery in this test's domain (the node
    must exit before rclpy starts, but if it did start it would stay on this machine)."""
    import os

    return dict(
        os.environ,
        ROS_DOMAIN_ID=str(ros_domain_id),
        ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
        ROS_STATIC_PEERS="",
    )


@pytest.mark.parametrize("launcher", LAUNCHERS)
@pytest.mark.parametrize(
    ("name", "text", "says"),
    [
        (None, None, "cannot read parameter file missing.yaml: No such file or directory"),
        ("broken.yaml", "/**:\n  ros__parameters:\n    face: [X, V\n",
         "parameter file broken.yaml is not valid YAML: "),
        ("flat.yaml", "face: V\nwidth_m: 0.05\n",
         "parameter file flat.yaml is not in ROS's layout: 'face' is a value where a node name"),
    ],
    ids=["missing", "bad-yaml", "not-a-params-layout"],
)  # fmt: skip
def test_a_parameter_file_the_node_cannot_use_is_one_line_and_exit_code_2(
    launcher: str,
    name: str | None,
    text: str | None,
    says: str,
    tmp_path: Path,
    node_env: dict[str, str],
) -> None:
    if name is not None and text is not None:
        (tmp_path / name).write_text(text, encoding="utf-8")
    code, stderr = run_node(launcher, name or "missing.yaml", tmp_path, node_env)
    assert code == 2, stderr
    assert len(stderr.splitlines()) == 1, stderr
    assert stderr.startswith(f"xface_predictor: error: {says}"), stderr
    assert "Traceback" not in stderr


def test_a_value_rcl_cannot_type_is_one_line_and_exit_code_2(
    tmp_path: Path, node_env: dict[str, str]
) -> None:
    # Valid YAML in ROS's layout that rcl still refuses: a list of mixed types.
    (tmp_path / "mixed.yaml").write_text(
        "/**:\n  ros__parameters:\n    face: [1, a]\n", encoding="utf-8"
    )
    code, stderr = run_node("python -m xface_ros", "mixed.yaml", tmp_path, node_env)
    assert code == 2, stderr
    assert len(stderr.splitlines()) == 1, stderr
    # rcl's own reason follows, without its source locations.
    assert stderr.startswith("xface_predictor: error: cannot use parameter file mixed.yaml: ")
    assert "parse.c" not in stderr


@pytest.mark.parametrize(
    ("data", "problem"),
    [
        ({"/**": {"ros__parameters": {"face": "V"}}}, None),
        ({"left": {"dock_left": {"ros__parameters": {"face": "V"}}}}, None),  # namespaces nest
        ({"n": {"ros__parameters": {"a": {"b": 1}}}}, None),  # a.b
        (None, "expected '<node name or /**>:', then 'ros__parameters:', then 'name: value'"),
        ("face: V", "expected '<node name or /**>:'"),
        ({"ros__parameters": {"face": "V"}}, "'ros__parameters:' needs a node name"),
        ({"/**": {"ros__parameters": 5}}, "'/**/ros__parameters' must map parameter names"),
        ({"n": {"ros__parameters": {}, "x": 3}}, "'n/x' is a value where a node name"),
    ],
)
def test_the_layout_check_takes_what_rcl_takes_and_names_what_is_off(
    data: object, problem: str | None
) -> None:
    found = params_layout_problem(data)
    if problem is None:
        assert found is None
    else:
        assert found is not None
        assert found.startswith(problem)
