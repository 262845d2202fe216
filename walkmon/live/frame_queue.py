"""A bounded, thread-safe queue in which the newest item wins.

When the consumer falls behind, :meth:`FrameQueue.put` drops the *oldest* queued item to make room and counts
it, so memory stays bounded and the consumer always works on the most recent frames. Sources that are not live
(a file or the simulator read as fast as possible) use :meth:`FrameQueue.put_wait` instead: back-pressure,
no drops. Used between the frame
grabber thread and the processing loop of :mod:`walkmon.live.pipeline`.
"""

from __future__ import annotations

import collections
import threading
from typing import Generic, TypeVar

__all__ = ["FrameQueue", "QueueClosed"]

T = TypeVar("T")


class QueueClosed(Exception):  # noqa: N818 - a control-flow signal, not an error
    """Raised by :meth:`FrameQueue.get` once the queue is closed and drained."""


class FrameQueue(Generic[T]):
    """Bounded FIFO; a put on a full queue drops the oldest item and increments :attr:`dropped`."""

    def __init__(self, maxsize: int = 4) -> None:
        if maxsize < 1:
            msg = f"maxsize must be >= 1, got {maxsize}"
            raise ValueError(msg)
        self._maxsize = maxsize
        self._items: collections.deque[T] = collections.deque()
        self._cond = threading.Condition()
        self._dropped = 0
        self._put_count = 0
        self._closed = False

    @property
    def maxsize(self) -> int:
        return self._maxsize

    @property
    def dropped(self) -> int:
        """Items dropped so far because the queue was full."""
        with self._cond:
            return self._dropped

    @property
    def put_count(self) -> int:
        """Items offered to the queue so far (delivered + dropped + still queued)."""
        with self._cond:
            return self._put_count

    @property
    def closed(self) -> bool:
        with self._cond:
            return self._closed

    def __len__(self) -> int:
        with self._cond:
            return len(self._items)

    def put(self, item: T) -> int:
        """Enqueue ``item``; returns how many old items were dropped to make room (0 or 1). Never blocks."""
        with self._cond:
            if self._closed:
                return 0
            n_dropped = 0
            while len(self._items) >= self._maxsize:
                self._items.popleft()
                n_dropped += 1
            self._dropped += n_dropped
            self._put_count += 1
            self._items.append(item)
            self._cond.notify_all()
            return n_dropped

    def put_wait(self, item: T, timeout_s: float | None = None) -> bool:
        """Enqueue ``item``, waiting up to ``timeout_s`` for room instead of dropping (for sources that are not
        live, such as a file read as fast as possible). False if there was no room in time or the queue is closed.
        """
        with self._cond:
            if not self._closed and len(self._items) >= self._maxsize:
                self._cond.wait_for(lambda: self._closed or len(self._items) < self._maxsize, timeout=timeout_s)
            if self._closed or len(self._items) >= self._maxsize:
                return False
            self._put_count += 1
            self._items.append(item)
            self._cond.notify_all()
            return True

    def get(self, timeout_s: float | None = None) -> T | None:
        """Oldest queued item, waiting at most ``timeout_s``; ``None`` on timeout.

        Raises :class:`QueueClosed` when the queue is closed and nothing is left in it.
        """
        with self._cond:
            if not self._items and not self._closed:
                self._cond.wait_for(lambda: self._items or self._closed, timeout=timeout_s)
            if self._items:
                item = self._items.popleft()
                self._cond.notify_all()  # room for a waiting put_wait
                return item
            if self._closed:
                raise QueueClosed
            return None

    def close(self) -> None:
        """No more puts; pending items can still be read, then :meth:`get` raises :class:`QueueClosed`."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()
