"""FrameQueue: newest wins, drops the oldest and counts, thread-safe, closes cleanly."""

from __future__ import annotations

import threading

import pytest

from walkmon.live.frame_queue import FrameQueue, QueueClosed


def test_full_queue_drops_oldest_and_counts() -> None:
    q: FrameQueue[int] = FrameQueue(3)
    for i in range(10):
        q.put(i)
    assert q.dropped == 7
    assert [q.get(0), q.get(0), q.get(0)] == [7, 8, 9]
    assert q.get(0.01) is None


def test_get_after_close_drains_then_raises() -> None:
    q: FrameQueue[int] = FrameQueue(2)
    q.put(1)
    q.close()
    q.put(2)  # ignored after close
    assert q.get(0) == 1
    with pytest.raises(QueueClosed):
        q.get(0.01)


def test_rejects_bad_size() -> None:
    with pytest.raises(ValueError, match="maxsize"):
        FrameQueue(0)


def test_slow_consumer_sees_newest_frames_and_every_frame_is_accounted_for() -> None:
    """A producer thread outpaces a consumer that waits on each item: drops are counted, nothing is lost silently."""
    q: FrameQueue[int] = FrameQueue(4)
    n = 2000
    got: list[int] = []
    consumer_may_go = threading.Event()

    def producer() -> None:
        for i in range(n):
            q.put(i)
            if i == n // 2:
                consumer_may_go.set()
        q.close()

    th = threading.Thread(target=producer)
    th.start()
    assert consumer_may_go.wait(10)
    while True:
        try:
            item = q.get(1.0)
        except QueueClosed:
            break
        if item is not None:
            got.append(item)
    th.join(10)
    assert got == sorted(got)  # order kept
    assert got[-1] == n - 1  # the newest frame always arrives
    assert q.dropped > 0
    assert len(got) + q.dropped == n  # every frame is either delivered or counted as dropped
    assert q.put_count == n


def test_put_wait_applies_back_pressure_without_dropping() -> None:
    q: FrameQueue[int] = FrameQueue(2)
    assert q.put_wait(1, 0) and q.put_wait(2, 0)
    assert not q.put_wait(3, 0.01)  # full: refused, not dropped
    assert q.dropped == 0
    got: list[int] = []

    def consumer() -> None:
        while True:
            try:
                item = q.get(1.0)
            except QueueClosed:
                return
            if item is not None:
                got.append(item)

    th = threading.Thread(target=consumer)
    th.start()
    for i in range(3, 500):
        assert q.put_wait(i, 5.0)
    q.close()
    th.join(10)
    assert got == list(range(1, 500)) and q.dropped == 0
