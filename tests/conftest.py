"""Suite-wide set-up: ROS isolation, markers, Hypothesis profiles.

Importing this file (pytest does it before collecting anything) puts every process the tests
start on loopback: DDS discovery limited to this host, no static peers, and a ROS domain id
of this run's own unless the caller chose one. Tests that start rclpy take the
:func:`ros_domain_id` fixture on top, which gives each of them a domain of its own.
"""

from __future__ import annotations

import fcntl
import importlib.util
import itertools
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

import hypothesis
import pytest

#: Domain ids handed to single tests; the run-level default lies in 1..99 (see the Makefile).
TEST_DOMAIN_IDS = range(100, 200)

# Before any test module (and so any rclpy) is imported: these are read when a ROS context
# is created, in this process and in every subprocess that inherits the environment.
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ["ROS_STATIC_PEERS"] = ""
if not os.environ.get("ROS_DOMAIN_ID"):
    os.environ["ROS_DOMAIN_ID"] = str(os.getpid() % 99 + 1)

# Hypothesis: no deadline (wall time on a shared machine says nothing about correctness, and
# the first call of a numba kernel compiles it); in CI the examples are derandomised so a
# failure reproduces from the log.
hypothesis.settings.register_profile("dev", deadline=None, print_blob=True)
hypothesis.settings.register_profile(
    "ci", deadline=None, print_blob=True, derandomize=True, database=None
)
hypothesis.settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "dev"))

_TESTS_DIR = Path(__file__).resolve().parent
_ROS_TESTS_DIR = _TESTS_DIR / "ros"
_RCLPY_AVAILABLE = importlib.util.find_spec("rclpy") is not None
_ROS_REQUIRED = os.environ.get("XFACE_REQUIRE_ROS", "0") == "1"

# Without rclpy the ROS tests cannot even be imported: leave them out of collection (unless
# the run installed the ROS extra and so promised rclpy; then pytest_configure fails loudly).
# (The directory itself, not "ros/*": a glob would still import tests/ros/conftest.py.)
collect_ignore = [] if _RCLPY_AVAILABLE else ["ros"]


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers",
        "slow: a heavy stress test (seconds to minutes); still part of `make test` and CI, "
        "deselect locally with -m 'not slow'",
    )
    config.addinivalue_line(
        "markers",
        "ros: needs rclpy and the ROS message packages (every test under tests/ros gets it)",
    )
    if _ROS_REQUIRED and not _RCLPY_AVAILABLE:
        raise pytest.UsageError(
            "XFACE_REQUIRE_ROS=1 but rclpy is not importable: install the extra with "
            "`pip install -e '.[ros,test]'` (or run `make test`, which does)"
        )
    if _ROS_REQUIRED and importlib.util.find_spec("xface_msgs") is None:
        raise pytest.UsageError(
            "XFACE_REQUIRE_ROS=1 but the ROS interfaces xface_msgs are not built: run "
            "`make msgs` (or `python scripts/build_msgs.py --prefix .venv`)"
        )


def pytest_report_header(config: pytest.Config) -> list[str]:
    ros = "rclpy available" if _RCLPY_AVAILABLE else "rclpy NOT available: tests/ros skipped"
    domain = os.environ["ROS_DOMAIN_ID"]
    discovery = os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"]
    profile = hypothesis.settings.get_current_profile_name()
    return [
        f"xface: {ros}; hypothesis profile {profile}",
        f"xface: ROS_DOMAIN_ID={domain} (tests 100-199), ROS_AUTOMATIC_DISCOVERY_RANGE={discovery}",
    ]


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        if _ROS_TESTS_DIR in item.path.parents:
            item.add_marker(pytest.mark.ros)


class DomainIdAllocator:
    """Hands out ROS domain ids from ``ids`` in turn, starting at an offset of this run's.

    Consecutive tests get distinct ids; the start depends on the process id. With a
    ``lock_dir``, an id is also locked (``flock`` on a file there) from :meth:`allocate`
    until :meth:`release`, and an id that another test session on this machine holds, or
    that this one still holds (a module's shared node), is passed over: two sessions at once
    (a CI run beside a developer's) once walked the same ids, and one's client saw the
    other's node.

    >>> allocator = DomainIdAllocator(range(100, 103), start=1)
    >>> [allocator.allocate() for _ in range(4)]
    [101, 102, 100, 101]
    """

    def __init__(self, ids: range, *, start: int, lock_dir: Path | None = None) -> None:
        if len(ids) == 0:
            raise ValueError("ids must not be empty")
        self._n = len(ids)
        self._ids: Iterator[int] = itertools.islice(itertools.cycle(ids), start % len(ids), None)
        self._lock_dir = lock_dir
        self._held: dict[int, int] = {}  # domain id -> the open lock file's descriptor

    def allocate(self) -> int:
        """The next domain id (with a ``lock_dir``: the next one nobody holds, now locked)."""
        for _ in range(self._n):
            domain_id = next(self._ids)
            if self._lock_dir is None:
                return domain_id
            if domain_id not in self._held and self._lock(domain_id):
                return domain_id
        raise RuntimeError(f"all {self._n} test ROS domain ids are held by running test sessions")

    def release(self, domain_id: int) -> None:
        """Unlock ``domain_id`` (nothing happens for an id this allocator does not hold)."""
        fd = self._held.pop(domain_id, None)
        if fd is not None:
            os.close(fd)  # closing the descriptor drops its flock

    def _lock(self, domain_id: int) -> bool:
        assert self._lock_dir is not None
        path = self._lock_dir / f"xface-test-ros-domain-{domain_id}.lock"
        fd = os.open(path, os.O_CREAT | os.O_RDWR, 0o666)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:  # another session holds it
            os.close(fd)
            return False
        self._held[domain_id] = fd
        return True


@pytest.fixture(scope="session")
def ros_domain_allocator() -> DomainIdAllocator:
    """The allocator behind :func:`ros_domain_id`, one per test session, its locks in the
    machine's temporary folder."""
    return DomainIdAllocator(
        TEST_DOMAIN_IDS, start=os.getpid(), lock_dir=Path(tempfile.gettempdir())
    )


@pytest.fixture
def ros_domain_id(
    ros_domain_allocator: DomainIdAllocator, monkeypatch: pytest.MonkeyPatch
) -> Iterator[int]:
    """A ROS domain id (100..199) for this test alone, also set as ``ROS_DOMAIN_ID``.

    Pass it to ``rclpy.init(domain_id=...)`` or rely on the environment variable, which
    subprocesses started by the test inherit; the variable is restored after the test, and
    the id released after the fixtures that use it (the nodes they started) are torn down.
    """
    domain_id = ros_domain_allocator.allocate()
    monkeypatch.setenv("ROS_DOMAIN_ID", str(domain_id))
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    yield domain_id
    ros_domain_allocator.release(domain_id)
