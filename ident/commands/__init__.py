"""Subcommands of the `ident` console script, one module each.

Each module defines `add_parser(subparsers) -> None` (which sets `func=run` on its parser)
and `run(args) -> int`. Heavy imports (scipy, control, matplotlib) go inside `run`, so
`ident --help` stays fast.
"""
