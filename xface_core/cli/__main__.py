"""``python -m xface_core.cli``: the ``xface`` command line."""

from __future__ import annotations

from .commands import main

if __name__ == "__main__":
    raise SystemExit(main())
