"""An independent cross-check of xface in Chipmunk2D (pymunk): the ``crosscheck`` extra.

``pip install '.[crosscheck]'`` in the xface checkout; ``import xface_core`` never imports
this package.
:func:`crosscheck` runs xface and the engine on the same cells and reports agreement,
ambiguous cells and every disagreement; :func:`run_cell` is one engine run.
See ``docs/crosscheck.md``.
"""

from __future__ import annotations

from .compare import (
    CrosscheckResult,
    Disagreement,
    EngineMap,
    compare_with_engine,
    crosscheck,
    engine_map,
    random_cells,
)
from .scene import DEFAULT_ENGINE, EngineRun, EngineSettings, classify, run_cell

__all__ = [
    "DEFAULT_ENGINE",
    "CrosscheckResult",
    "Disagreement",
    "EngineMap",
    "EngineRun",
    "EngineSettings",
    "classify",
    "compare_with_engine",
    "crosscheck",
    "engine_map",
    "random_cells",
    "run_cell",
]
