"""A parameter file the node cannot use is a user error: one line on stderr, exit code 2.

rcl refuses a missing file or broken YAML with a traceback (exit code 1) and runs without a
word on a file that is YAML but sets nothing; the node checks its ``--params-file`` arguments
before rclpy starts (a FIFO or a device without opening it). Both ways of starting it are
tested: ``python -m xface_ros`` and the ``xface-predictor`` command the install puts beside
the interpreter. A parameter the node does not have (a misspelt name) is warned about.
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import pytest

from xface_ros.node import params_file_problem, params_layout_problem

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


#: How long a test waits for a check that should answer at once before it unblocks the check
#: itself (the test then fails): a hang guard, not a timing assertion.
HANG_GUARD_S = 30.0


def test_a_fifo_parameter_file_is_refused_without_being_opened(tmp_path: Path) -> None:
    fifo = tmp_path / "params.yaml"
    os.mkfifo(fifo)
    problem: list[str | None] = []
    check = threading.Thread(target=lambda: problem.append(params_file_problem(str(fifo))))
    check.start()
    check.join(HANG_GUARD_S)
    if check.is_alive():
        with open(fifo, "w", encoding="utf-8"):  # what a blocked open(fifo) waits for
            pass
        check.join(HANG_GUARD_S)
        pytest.fail("the parameter file check blocked on a FIFO")
    assert problem == [f"cannot read parameter file {fifo}: it is a FIFO, not a regular file"]


@pytest.mark.parametrize(
    ("text", "says"),
    [
        ("/**:\n  ros__parameters:\n    face: " + "[" * 10_000 + "]" * 10_000 + "\n",
         "parameter file {path} is nested too deeply to read"),
        ("/**:\n  ros__parameters:\n    width_m: " + "9" * 5000 + "\n",
         "cannot read parameter file {path}: ValueError: Exceeds the limit (4300 digits)"),
    ],
    ids=["nested-10000-deep", "5000-digit-number"],
)  # fmt: skip
def test_a_hostile_parameter_file_is_refused_in_one_line(
    text: str, says: str, tmp_path: Path
) -> None:
    path = tmp_path / "hostile.yaml"
    path.write_text(text, encoding="utf-8")
    problem = params_file_problem(str(path))
    assert problem is not None
    assert problem.startswith(says.format(path=path)), problem
    assert len(problem.splitlines()) == 1


def test_dev_zero_as_a_parameter_file_is_refused_without_being_read() -> None:
    assert params_file_problem("/dev/zero") == (
        "cannot read parameter file /dev/zero: it is a character device, not a regular file"
    )


def test_a_misspelt_parameter_is_warned_about_with_the_closest_name(launch: Any) -> None:
    running = launch(wait=False, widht_m=0.1)
    deadline = time.monotonic() + 120.0  # rclpy's import and init, on a busy machine
    warning = "unknown parameters, ignored: widht_m (did you mean width_m?)"
    while warning not in running.node.log():
        if running.node.process.poll() is not None or time.monotonic() > deadline:
            pytest.fail(f"no warning about widht_m:\n{running.node.log()}")
        time.sleep(0.1)
    running.client.wait_for_node(running.node)  # and the node runs on
    assert running.node.log().count("unknown parameters") == 1
