"""``python -m walkmon``: the ``walkmon`` command."""

from walkmon.commands.entry import main

raise SystemExit(main())
