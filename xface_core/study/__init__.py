"""Questions asked of many designs: which face, which H/D and r_p, for this friction?

- :mod:`.space`: design spaces, the product of faces, H/D, r_p, friction and damping ratio.
- :mod:`.run`: a design study, one table row per design, written as results arrive and
  resumable.
- :mod:`.table`: the study's Parquet table (rows, parts, resume).
- :mod:`.noise`: the mean seat probability of a design over a grid, under pose noise.
- :mod:`.search`: the best H/D and r_p of one face in a box, by a criterion.
- :mod:`.executors`: running the designs on local processes or a Dask client, with retries.
- :mod:`.cluster`: a Dask cluster on this machine from a ``--scheduler`` argument.

``from xface_core.study import run_study`` keeps working: this package re-exports what the
module ``xface_core.study`` exported before the regroup.
"""

from __future__ import annotations

# The module's exports as they were (its __all__ is the one list of them).
from .run import *  # noqa: F403
from .run import __all__ as __all__
