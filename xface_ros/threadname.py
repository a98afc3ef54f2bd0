"""The node's own threads named for the operating system (``top -H``, ``perf``, ``ps -L``).

Python 3.11 names a ``threading.Thread`` for Python only; every thread of the process shows
the program's name to the kernel, so the worker's CPU cannot be told from the executor's
(scripts/bench/ros_stress.py reports CPU per thread name). Linux only; elsewhere, or if the call
fails, the thread keeps its name: naming is a convenience, never a reason to fail.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import sys

__all__ = ["name_os_thread"]

#: prctl option that sets the calling thread's name (linux/prctl.h).
_PR_SET_NAME = 15
#: The kernel keeps 15 bytes of a thread's name (and a terminating NUL).
_NAME_BYTES = 15


def name_os_thread(name: str) -> bool:
    """Give the calling thread ``name`` (cut to 15 bytes) in /proc/<pid>/task/<tid>/comm;
    True if it took."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        raw = name.encode("ascii", "replace")[:_NAME_BYTES]
        return int(libc.prctl(_PR_SET_NAME, ctypes.c_char_p(raw), 0, 0, 0)) == 0
    except (OSError, AttributeError):
        return False
