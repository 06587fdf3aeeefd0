"""Old option names kept as deprecated aliases: accepted, hidden from --help, and noted on stderr.

One name per option across the `ident` and `daq` commands (units in the name, as in the
records: `--step-m`, `--rate-hz`); an old spelling keeps working for a while and says which
name to use.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any


class _DeprecatedAlias(argparse.Action):
    def __init__(self, option_strings: Sequence[str], dest: str, new_name: str = "", **kwargs: Any) -> None:
        self.new_name = new_name
        super().__init__(option_strings, dest, **kwargs)

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: Any, option_string: str | None = None) -> None:
        print(f"{parser.prog}: {option_string} is deprecated, use {self.new_name}", file=sys.stderr)
        setattr(namespace, self.dest, values)


def add_deprecated_alias(parser: argparse.ArgumentParser, old: str, new: str, dest: str, kind: type) -> None:
    """Accept `old` as a hidden spelling of the option `new` (same `dest`, same type)."""
    parser.add_argument(old, dest=dest, type=kind, action=_DeprecatedAlias, new_name=new,
                        help=argparse.SUPPRESS, default=argparse.SUPPRESS)
