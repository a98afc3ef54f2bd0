"""The newest-pose-wins slot between the subscription and the prediction worker."""

from __future__ import annotations

import threading

from xface_ros.latest import LatestSlot


def test_newest_wins_and_overwrites_are_counted() -> None:
    slot: LatestSlot[int] = LatestSlot()
    for i in range(5):
        slot.put(i, receive_ns=i)
    item = slot.take(timeout_s=0.0)
    assert item is not None
    assert item.message == 4
    assert item.receive_ns == 4
    assert slot.dropped == 4
    assert slot.received == 5
    assert slot.take(timeout_s=0.0) is None


def test_latest_survives_take_for_use_latest_queries() -> None:
    slot: LatestSlot[str] = LatestSlot()
    assert slot.latest is None
    slot.put("pose", receive_ns=1)
    slot.take(timeout_s=0.0)
    latest = slot.latest
    assert latest is not None
    assert latest.message == "pose"


def test_every_input_is_either_taken_or_counted_as_dropped() -> None:
    slot: LatestSlot[int] = LatestSlot()
    taken: list[int] = []
    done = threading.Event()

    def consume() -> None:
        while not done.is_set() or slot.take(timeout_s=0.0) is not None:
            item = slot.take(timeout_s=0.01)
            if item is not None:
                taken.append(item.message)

    consumer = threading.Thread(target=consume)
    consumer.start()
    n = 20000
    for i in range(n):
        slot.put(i, receive_ns=i)
    done.set()
    consumer.join(timeout=30.0)
    final = slot.take(timeout_s=0.0)
    if final is not None:
        taken.append(final.message)
    assert slot.received == n
    assert len(taken) + slot.dropped == n
    assert taken == sorted(taken)  # never an older input after a newer one
    assert taken[-1] == n - 1  # the newest is never lost


def test_close_wakes_a_waiting_taker() -> None:
    slot: LatestSlot[int] = LatestSlot()
    result: list[object] = []
    taker = threading.Thread(target=lambda: result.append(slot.take(timeout_s=60.0)))
    taker.start()
    slot.close()
    taker.join(timeout=10.0)
    assert not taker.is_alive()
    assert result == [None]
