"""One module per ``walkmon`` subcommand: ``NAME``, ``HELP``, ``add_arguments(parser)``, ``run(args) -> int``."""
