"""The live monitor: pipeline threads, frame queue, alerts and their sinks, systemd notification, the config file
and the session log (SQLite). The only package that starts threads or touches sockets and SQLite.

Submodules are imported where used (``walkmon.live.pipeline`` pulls in the sources); this module names nothing
so that ``import walkmon.live.session_log`` stays light for the read-only commands.
"""
