"""What the wearer and the clinician see: pages, figures and words (pure: no I/O, no SQLite, no sockets).

* :mod:`walkmon.views.render`: the Jinja2 environment (autoescaping on) and its filters;
* :mod:`walkmon.views.history`: per-session statistics and their per-day aggregate;
* :mod:`walkmon.views.svg`: the session timeline and the history trend as inline SVG;
* ``templates/``: the dashboard's pages, ``history.html`` and the report's first page; ``static/``: the
  dashboard's stylesheet and the live page's script (served by the app itself, nothing from other hosts).

The data come from :mod:`walkmon.serve.store` (the session database, read-only) or from analysis outputs.
"""
