"""One writer per study: an OS file lock on ``<table>.lock`` beside the study's table.

Why ``fcntl.flock`` and not a pid file made with ``O_EXCL``: the kernel releases the lock when
its holder exits, however it exits (SIGKILL, a crash, a lost node's reboot), so a killed sweep
never leaves a lock that the next run must judge stale by guessing whether a pid still lives
(pids are reused). Why not ``fcntl.lockf`` (POSIX record locks): those vanish as soon as the
process closes *any* descriptor of the file, and belong to the process, not to the open file.
``flock`` belongs to the open file description; the workers a sweep forks would inherit it, so
a fork hook closes their copy (a worker orphaned by a killed sweep must not keep the study
locked). On Linux ``flock`` on NFS is mapped to byte-range locks and works across machines.

The lock file is removed by its holder on release while still holding it; whoever opened the
old file meanwhile sees, after locking it, that the name now points elsewhere and tries again
(the usual unlink-safe protocol). A file left by a killed holder is reused. It holds the
holder's pid and host, for the error of whoever finds it taken.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import socket
import time
from pathlib import Path

from xface_core.errors import XfaceValueError

__all__ = ["LOCK_SUFFIX", "StudyBusy", "StudyLock"]

#: Appended to the table's name: ``study.parquet.lock``.
LOCK_SUFFIX = ".lock"

#: Seconds to wait for the holder to have written its pid (it writes it just after locking).
_PID_WAIT_S = 1.0

#: Times to retry when the lock file was replaced between opening and locking it.
_ATTEMPTS = 20

#: Descriptors of the locks this process holds: closed in a forked child (see above).
_HELD: set[int] = set()


def _close_inherited() -> None:
    for fd in _HELD:
        with contextlib.suppress(OSError):
            os.close(fd)
    _HELD.clear()


os.register_at_fork(after_in_child=_close_inherited)


class StudyBusy(XfaceValueError):
    """Another process (another sweep) holds the lock of the study."""


def _holder(fd: int) -> str:
    """The pid (and host, when not this one) written in a held lock file."""
    deadline = time.monotonic() + _PID_WAIT_S
    while True:
        try:
            words = os.pread(fd, 256, 0).decode(errors="replace").split()
        except OSError:
            words = []
        if len(words) >= 2 or time.monotonic() > deadline:
            break
        time.sleep(0.02)
    if not words:
        return "pid unknown"
    pid = f"pid {words[0]}"
    host = words[1] if len(words) > 1 else ""
    return pid if host in ("", socket.gethostname()) else f"{pid} on {host}"


class StudyLock:
    """The exclusive lock of the study whose table is ``table``; a context manager.

    Raises :class:`StudyBusy` when another process holds it, and
    :class:`~xface_core.errors.XfaceValueError` when the lock file cannot be made or locked.
    """

    def __init__(self, table: str | os.PathLike[str]) -> None:
        self.table = Path(table)
        self.path = self.table.with_name(self.table.name + LOCK_SUFFIX)
        self._fd: int | None = None

    @property
    def held(self) -> bool:
        return self._fd is not None

    def acquire(self) -> None:
        for _ in range(_ATTEMPTS):
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o666)
            except OSError as exc:
                raise XfaceValueError(
                    f"cannot write the study to {self.table}: {exc.strerror}"
                ) from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = _holder(fd)
                os.close(fd)
                raise StudyBusy(
                    f"another sweep is writing this study ({holder}): {self.table}; "
                    "wait for it to end, or write to another --out"
                ) from None
            except OSError as exc:  # ENOLCK: a file system without locks
                os.close(fd)
                raise XfaceValueError(f"cannot lock {self.path}: {exc.strerror}") from None
            if self._still_named(fd):
                os.ftruncate(fd, 0)
                os.pwrite(fd, f"{os.getpid()} {socket.gethostname()}\n".encode(), 0)
                self._fd = fd
                _HELD.add(fd)
                return
            os.close(fd)  # its holder removed it as we opened it: lock the new one
        raise XfaceValueError(f"cannot lock {self.path}: it keeps being replaced")

    def _still_named(self, fd: int) -> bool:
        try:
            named = os.stat(self.path)
        except FileNotFoundError:
            return False
        held = os.fstat(fd)
        return (named.st_dev, named.st_ino) == (held.st_dev, held.st_ino)

    def release(self) -> None:
        """Remove the lock file (while still holding it) and unlock; idempotent."""
        fd, self._fd = self._fd, None
        if fd is None:
            return
        with contextlib.suppress(OSError):  # left behind: the next run reuses it
            self.path.unlink()
        _HELD.discard(fd)
        os.close(fd)

    def __enter__(self) -> StudyLock:
        self.acquire()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.release()
