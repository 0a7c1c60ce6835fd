"""One module per ``voxelmocap`` subcommand: ``add_parser(subparsers)`` and ``run(args) -> int``."""
