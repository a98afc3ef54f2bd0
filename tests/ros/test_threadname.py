"""xface_ros.threadname: the node's threads named for the operating system."""

from __future__ import annotations

import sys
import threading
from pathlib import Path

import pytest

from xface_ros.threadname import name_os_thread

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="Linux names")


def _named_in_thread(name: str) -> tuple[bool, str]:
    """Name a fresh thread ``name``; whether it took and its name in /proc."""
    seen: list[tuple[bool, str]] = []

    def run() -> None:
        took = name_os_thread(name)
        comm = Path(f"/proc/self/task/{threading.get_native_id()}/comm").read_text().strip()
        seen.append((took, comm))

    thread = threading.Thread(target=run)
    thread.start()
    thread.join()
    return seen[0]


def test_a_thread_shows_its_name_in_proc() -> None:
    assert _named_in_thread("xface_atlas") == (True, "xface_atlas")


def test_a_long_name_is_cut_to_the_kernels_fifteen_bytes() -> None:
    assert _named_in_thread("xface_predictor_with_a_long_tail") == (True, "xface_predictor")


def test_naming_a_thread_leaves_the_process_name() -> None:
    before = Path("/proc/self/comm").read_text()
    _named_in_thread("xface_other")
    assert Path("/proc/self/comm").read_text() == before
