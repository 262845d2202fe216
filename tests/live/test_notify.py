"""The apprise sink: alerts reach a notification service (here apprise's json:// to a local HTTP listener,
standing in for ntfy, Telegram or mail) without blocking the session, with the session, person and alert."""

from __future__ import annotations

import http.server
import json
import threading
import time
from typing import Any

import pytest

from walkmon.live.alerts import AlertEvent
from walkmon.live.sinks import AlertSinks, SinkSettings


class _Listener(http.server.BaseHTTPRequestHandler):
    received: list[dict[str, Any]] = []

    def do_POST(self) -> None:  # noqa: N802 - http.server's name
        body = self.rfile.read(int(self.headers["Content-Length"]))
        type(self).received.append(json.loads(body))
        self.send_response(200)
        self.end_headers()

    def log_message(self, *args: object) -> None:
        pass


def test_alerts_reach_an_apprise_service(caplog: pytest.LogCaptureFixture) -> None:
    pytest.importorskip("apprise", reason="apprise is not installed (notify/test extra)")
    _Listener.received = []
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _Listener)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        port = server.server_address[1]
        sinks = AlertSinks(SinkSettings(terminal=False, apprise_urls=(f"json://127.0.0.1:{port}/",)),
                           session_id=12, person="Ann")
        t0 = time.monotonic()
        sinks.deliver([AlertEvent(30.0, "lean_forward", "raised", 14.0, 10.0, "leaning forward 14 deg: straighten up"),
                       AlertEvent(40.0, "lean_forward", "cleared", 5.0, 7.0, "lean forward: cleared")])
        assert time.monotonic() - t0 < 0.2  # the network is the worker thread's business
        sinks.close()
    finally:
        server.shutdown()
        server.server_close()
    assert len(_Listener.received) == 1  # the clear is not sent without hook_on_clear
    msg = _Listener.received[0]
    assert msg["title"] == "walkmon (Ann): lean forward raised"
    assert msg["message"].startswith("leaning forward 14 deg: straighten up (session 12, ")


def test_a_bad_apprise_url_is_a_warning_not_an_error(caplog: pytest.LogCaptureFixture) -> None:
    pytest.importorskip("apprise", reason="apprise is not installed (notify/test extra)")
    sinks = AlertSinks(SinkSettings(terminal=False, apprise_urls=("nonsense-scheme://x",)))
    sinks.deliver([AlertEvent(1.0, "lean_forward", "raised", 14.0, 10.0, "m")])
    sinks.close()
    assert "no usable URL" in caplog.text
