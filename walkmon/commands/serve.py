"""``walkmon serve``: the local dashboard (live page, sessions, history) over the session database."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

NAME = "serve"
HELP = "local web dashboard: live posture, sessions, history (read-only; loopback unless a token is given)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--data-dir", metavar="DIR", help="session database folder (default: config, else "
                   "~/.local/share/walkmon)")
    p.add_argument("--host", help="address to listen on (default: config, else 127.0.0.1); anything but loopback "
                   "needs --token")
    p.add_argument("--port", type=int, help="TCP port (default: config, else 8765)")
    p.add_argument("--token", help="require this token on every request (Authorization: Bearer TOKEN, or open "
                   "the page once with ?token=TOKEN); default: [serve] token of the config")
    p.add_argument("--config", metavar="TOML", help="configuration file ([serve] and [session] sections)")


def run(args: argparse.Namespace) -> int:
    from walkmon.errors import ConfigError  # noqa: PLC0415
    from walkmon.live.config import DEFAULT_CONFIG, read_config  # noqa: PLC0415
    from walkmon.live.session_log import default_data_dir  # noqa: PLC0415
    from walkmon.serve.server import check_port, make_server, url, warm_up  # noqa: PLC0415

    cfg = read_config(args.config) if args.config else DEFAULT_CONFIG
    host = args.host or cfg.serve.host
    port = cfg.serve.port if args.port is None else args.port
    if not 0 < port < 65536:
        msg = f"--port must be in 1..65535, got {port}"
        raise ConfigError(msg)
    token = args.token if args.token is not None else cfg.serve.token
    data_dir = Path(args.data_dir or cfg.session.data_dir or default_data_dir()).expanduser()
    server = make_server(data_dir, host, port, token)
    check_port(host, port)
    warm_up(server)
    sys.stderr.write(f"walkmon dashboard on {url(host, port)} (database {data_dir}; Ctrl-C stops)\n")
    server.run()
    return 0
