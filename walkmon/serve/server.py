"""Run the dashboard with uvicorn: in the foreground (``walkmon serve``) or in a thread of ``walkmon live``."""

from __future__ import annotations

import logging
import secrets
import threading
from pathlib import Path
from typing import Any

from walkmon.errors import ConfigError

__all__ = ["DashboardThread", "check_binding", "check_port", "make_server", "url", "warm_up"]

_log = logging.getLogger(__name__)


def check_binding(host: str, token: str) -> None:
    """Refuse to listen beyond loopback without a token (ConfigError with the way out)."""
    from walkmon.serve.app import is_loopback  # noqa: PLC0415

    if not is_loopback(host) and not token:
        msg = (f"listening on {host} (not loopback) needs a token: pass --token (e.g. {secrets.token_urlsafe(16)}) "
               "or set [serve] token in the config; requests without it get 401")
        raise ConfigError(msg)
    if token and len(token) < 12:
        msg = "the token must have at least 12 characters"
        raise ConfigError(msg)


def check_port(host: str, port: int) -> None:
    """A port already taken (or an address not on this machine) is one ConfigError line, not uvicorn's log (and,
    in a thread of 'walkmon live', its traceback: user review)."""
    import socket  # noqa: PLC0415

    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
        family, _, _, _, addr = infos[0]
        with socket.socket(family, socket.SOCK_STREAM) as s:
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            s.bind(addr)
    except OSError as exc:
        msg = f"cannot listen on {host}:{port}: {exc.strerror or exc}"
        raise ConfigError(msg) from exc


def url(host: str, port: int) -> str:
    """The dashboard's address: an IPv6 host in brackets (``http://[::1]:8765/``; user review: ``::1:8765``)."""
    return f"http://[{host}]:{port}/" if ":" in host else f"http://{host}:{port}/"


def make_server(data_dir: str | Path, host: str = "127.0.0.1", port: int = 8765, token: str = "") -> Any:
    """A ``uvicorn.Server`` for the dashboard (not started); ConfigError without the serve extra."""
    check_binding(host, token)
    try:
        import uvicorn  # noqa: PLC0415

        from walkmon.serve.app import create_app  # noqa: PLC0415
    except ImportError as exc:
        msg = f"the dashboard needs the serve extra (pip install 'walkmon[serve]'): {exc}"
        raise ConfigError(msg) from exc
    app = create_app(data_dir, token=token, bound_host=host)
    config = uvicorn.Config(app, host=host, port=port, log_level="warning", access_log=False, lifespan="off",
                            server_header=False, timeout_keep_alive=5)
    return uvicorn.Server(config)


def warm_up(server: Any) -> threading.Thread:
    """Compute the ended sessions' statistics once in the background (they are cached and never change), so the
    first history page after a start does not pay for the whole database; a failure only logs."""

    def run() -> None:
        try:
            server.config.app.state.store.session_stats()
        except Exception as exc:  # noqa: BLE001 - no database yet, or unreadable: the pages will say so
            _log.info("dashboard warm-up skipped: %s", exc)

    th = threading.Thread(target=run, name="walkmon-dashboard-warmup", daemon=True)
    th.start()
    return th


class DashboardThread:
    """The dashboard in a daemon thread (``[serve] enabled`` in ``walkmon live``); ``stop()`` ends it."""

    def __init__(self, data_dir: str | Path, host: str, port: int, token: str = "") -> None:
        self.server = make_server(data_dir, host, port, token)
        self.host, self.port = host, port
        self.url = url(host, port)
        self._thread = threading.Thread(target=self._run, name="walkmon-dashboard", daemon=True)

    def _run(self) -> None:
        try:
            self.server.run()
        except BaseException as exc:  # noqa: BLE001 - a failing dashboard must never end the monitoring (one line)
            _log.warning("dashboard stopped: %s", exc if str(exc) else type(exc).__name__)

    def start(self) -> DashboardThread:
        """Start serving (ConfigError, one line, when the port is taken: the monitor goes on without it)."""
        check_port(self.host, self.port)
        self._thread.start()
        warm_up(self.server)
        return self

    def stop(self, timeout_s: float = 5.0) -> None:
        self.server.should_exit = True
        self._thread.join(timeout_s)
