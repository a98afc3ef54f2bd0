"""Questions asked of one design over a grid of starting poses.

- :mod:`.acceptance`: acceptance maps over (x0, theta0) grids, and M tables over designs.
- :mod:`.grids`: the grids of starting poses and the paper's design axes.
- :mod:`.regions`: guaranteed-acceptance rectangles of a map.
- :mod:`.paper`: the paper's Tables II-IV as packaged data.
- :mod:`.bounds`: the paper's closed-form "best case" bounds for the V- and S-Face.
"""

from __future__ import annotations

from .acceptance import AcceptanceMap, MTable, acceptance_map, m_table

__all__ = ["AcceptanceMap", "MTable", "acceptance_map", "m_table"]
