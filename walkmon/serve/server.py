"""Run the dashboard with uvicorn: in the foreground (``walkmon serve``) or in a thread of ``walkmon live``."""

from __future__ import annotations

import logging
import secrets
import threading
from pathlib import Path
from typing import Any

from walkmon.errors import ConfigError

__all__ = ["DashboardThread", "check_binding", "make_server", "warm_up"]

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
        self.url = f"http://{host}:{port}/"
        self._thread = threading.Thread(target=self._run, name="walkmon-dashboard", daemon=True)

    def _run(self) -> None:
        try:
            self.server.run()
        except BaseException:  # a failing dashboard must never end the monitoring
            _log.exception("dashboard server failed")

    def start(self) -> DashboardThread:
        self._thread.start()
        warm_up(self.server)
        return self

    def stop(self, timeout_s: float = 5.0) -> None:
        self.server.should_exit = True
        self._thread.join(timeout_s)
