"""The local dashboard (``walkmon serve``): a small Starlette app that shows the session database in a browser.

Besides :mod:`walkmon.live`, the only package that touches SQLite and sockets: :mod:`walkmon.serve.store` opens
the session database **read-only** (``file:...?mode=ro``: the dashboard can never change or lose a session), and
:mod:`walkmon.serve.app` / :mod:`walkmon.serve.server` answer HTTP on loopback by default (another address
needs a token). Pages and figures are rendered by :mod:`walkmon.views` (pure functions and Jinja2 templates).
Nothing is fetched from or sent to other hosts: scripts, styles and figures are served by the app itself.

Submodules are imported where used: :mod:`walkmon.serve.store` needs only the standard library, so
``walkmon history`` works without the ``serve`` extra (Starlette, uvicorn).
"""
