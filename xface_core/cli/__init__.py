"""The ``xface`` command line: one module per family of commands.

- :mod:`.commands`: the parser and the one-design commands (predict, map, compare, table,
  crosscheck), and the entry point :func:`main`.
- :mod:`.study`: the many-design commands (sweep, design).
- :mod:`.bench`: ``xface bench``, run time against error.
- :mod:`.progress`: one-line progress bars on a terminal.

``python -m xface_core.cli`` runs the command line.
"""

from __future__ import annotations

from .commands import build_parser, main

__all__ = ["build_parser", "main"]
