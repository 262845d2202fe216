"""systemd's notify protocol (sd_notify) without libsystemd: READY=1, WATCHDOG=1, STATUS=..., STOPPING=1.

Messages are datagrams sent to the AF_UNIX socket named by ``$NOTIFY_SOCKET`` (a path, or an abstract socket
written with a leading ``@``). Without ``$NOTIFY_SOCKET`` (not under systemd) every call is a no-op.
``$WATCHDOG_USEC`` (set by systemd when the unit has ``WatchdogSec=``) gives the watchdog period;
:meth:`Notifier.watchdog` rate-limits pings to half of it.
"""

from __future__ import annotations

import logging
import os
import socket
import time

__all__ = ["Notifier", "notify_socket_address"]

_log = logging.getLogger(__name__)


def notify_socket_address(value: str | None) -> str | bytes | None:
    """The address to send to for a ``$NOTIFY_SOCKET`` value: a path, or bytes with a NUL for '@abstract'."""
    if not value:
        return None
    if value.startswith("@"):
        return b"\0" + value[1:].encode()
    if value.startswith("/"):
        return value
    _log.warning("ignoring NOTIFY_SOCKET=%r: neither a path nor an abstract '@' socket", value)
    return None


class Notifier:
    """Send sd_notify messages; silent no-op when not started by systemd with a notify socket."""

    def __init__(self, environ: dict[str, str] | None = None) -> None:
        env = os.environ if environ is None else environ
        self._address = notify_socket_address(env.get("NOTIFY_SOCKET"))
        usec = env.get("WATCHDOG_USEC", "")
        pid = env.get("WATCHDOG_PID", "")
        self.watchdog_period_s: float | None = None
        if usec.isdigit() and int(usec) > 0 and (not pid or pid == str(os.getpid())):
            self.watchdog_period_s = int(usec) / 1e6
        self._sock: socket.socket | None = None
        self._last_ping = -1e18
        self._ready_sent = False
        self._failed = False

    @property
    def enabled(self) -> bool:
        return self._address is not None

    def send(self, message: str) -> bool:
        """Send one datagram (``KEY=VALUE`` lines); False if disabled or it failed (logged once)."""
        if self._address is None:
            return False
        try:
            if self._sock is None:
                self._sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM | socket.SOCK_CLOEXEC)
            # never block the processing loop: if the receiver's queue is full the message is dropped
            self._sock.sendto(message.encode(), socket.MSG_DONTWAIT, self._address)
        except BlockingIOError:
            _log.debug("sd_notify: socket queue full, %r dropped", message)
            return False
        except OSError as exc:
            if not self._failed:
                _log.warning("sd_notify to %r failed: %s", self._address, exc)
                self._failed = True
            return False
        return True

    def ready(self, status: str = "") -> bool:
        """READY=1 (once); with an optional STATUS= line."""
        if self._ready_sent:
            return False
        self._ready_sent = True
        return self.send("READY=1" + (f"\nSTATUS={status}" if status else ""))

    def status(self, text: str) -> bool:
        return self.send(f"STATUS={text}")

    def stopping(self) -> bool:
        return self.send("STOPPING=1")

    def watchdog(self, now_s: float | None = None) -> bool:
        """WATCHDOG=1, at most every half watchdog period (every call if no period is known)."""
        if self._address is None:
            return False
        now = time.monotonic() if now_s is None else now_s
        if self.watchdog_period_s is not None and now - self._last_ping < self.watchdog_period_s / 2:
            return False
        self._last_ping = now
        return self.send("WATCHDOG=1")

    def close(self) -> None:
        if self._sock is not None:
            self._sock.close()
            self._sock = None
