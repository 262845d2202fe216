"""``python -m walkmon``: the ``walkmon`` command."""

from walkmon.commands.cli import main

raise SystemExit(main())
