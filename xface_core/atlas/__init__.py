"""Questions asked around one pose of one design: how far is the next flip, how likely is a
seat under a pose covariance, which small correction makes the dock likely.

- :mod:`.build`: the acceptance atlas, one design's outcomes on a fine grid, built once.
- :mod:`.flips`: flips on the atlas's grid lines, bisected lazily.
- :mod:`.margins`: exact margins, by scanning and bisecting with simulations.
- :mod:`.lookup`: the same margins read from the atlas and confirmed by a few simulations.
- :mod:`.probability`: seat probability under a Gaussian pose, integrated over the atlas.
- :mod:`.approach`: the smallest pose correction that makes a dock likely (or safe).

``from xface_core.atlas import build_atlas`` keeps working: this package re-exports what the
module ``xface_core.atlas`` exported before the regroup.
"""

from __future__ import annotations

# The module's exports as they were (its __all__ is the one list of them).
from .build import *  # noqa: F403
from .build import __all__ as __all__
