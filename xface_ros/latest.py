"""A one-slot mailbox: the newest input wins, older unprocessed inputs are dropped and counted.

The subscription callback only puts the message here; the prediction worker takes the newest
one when it is free. Memory stays bounded however fast poses arrive.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Generic, TypeVar

__all__ = ["LatestSlot", "Received"]

T = TypeVar("T")


@dataclass(frozen=True)
class Received(Generic[T]):
    """An input and the node-clock time (ns) at which it arrived."""

    message: T
    receive_ns: int


class LatestSlot(Generic[T]):
    """Thread-safe holder of the newest input.

    Examples
    --------
    >>> slot: LatestSlot[str] = LatestSlot()
    >>> slot.put("a", receive_ns=1), slot.put("b", receive_ns=2)
    (False, True)
    >>> slot.take(timeout_s=0.0).message, slot.dropped, slot.received
    ('b', 1, 2)
    >>> slot.take(timeout_s=0.0) is None  # nothing new
    True
    >>> slot.latest.message  # still there for "use the latest pose"
    'b'
    """

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._pending: Received[T] | None = None
        self._latest: Received[T] | None = None
        self._dropped = 0
        self._received = 0
        self._closed = False

    def put(self, message: T, *, receive_ns: int) -> bool:
        """Store ``message`` as the newest input; True when it overwrote an unprocessed one."""
        item = Received(message, receive_ns)
        with self._cond:
            overwritten = self._pending is not None
            if overwritten:
                self._dropped += 1
            self._pending = item
            self._latest = item
            self._received += 1
            self._cond.notify()
        return overwritten

    def take(self, *, timeout_s: float | None) -> Received[T] | None:
        """Wait up to ``timeout_s`` for an unprocessed input and remove it from the slot.

        Returns None on timeout or once :meth:`close` was called.
        """
        with self._cond:
            if self._pending is None and not self._closed:
                self._cond.wait(timeout=timeout_s)
            if self._closed:
                return None
            item, self._pending = self._pending, None
            return item

    def close(self) -> None:
        """Wake every waiter; later :meth:`take` calls return None."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()

    @property
    def latest(self) -> Received[T] | None:
        """The newest input ever received, processed or not."""
        with self._cond:
            return self._latest

    @property
    def dropped(self) -> int:
        """Inputs overwritten before the worker took them."""
        with self._cond:
            return self._dropped

    @property
    def received(self) -> int:
        """Inputs put into the slot."""
        with self._cond:
            return self._received
