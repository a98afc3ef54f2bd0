"""Two acceptance maps of the same grid compared cell by cell: where each one seats.

numpy only (no matplotlib), so ``xface compare`` prints its counts without the viz extra;
the picture is :mod:`xface_core.viz.comparefig`.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numpy as np
import numpy.typing as npt

from xface_core.codes import Outcome
from xface_core.errors import XfaceValueError
from xface_core.viz.mapgrid import AcceptanceMapLike, checked_grid

__all__ = ["MapDifference", "SeatedIn", "map_difference"]


class SeatedIn(IntEnum):
    """Which of the two maps seats a cell."""

    NEITHER = 0
    ONLY_A = 1
    ONLY_B = 2
    BOTH = 3


@dataclass(frozen=True)
class MapDifference:
    """Cell-by-cell comparison of map A with map B on one grid.

    Attributes
    ----------
    seated_in : (n, m) int array
        :class:`SeatedIn` value per cell (rows x0, columns theta0, as in the maps).
    M_a, M_b : int
        SEATED cells of A and of B.
    same_outcome : int
        Cells with the same outcome in both maps (SEATED or any failure).
    """

    seated_in: npt.NDArray[np.int64]
    M_a: int
    M_b: int
    same_outcome: int

    def count(self, which: SeatedIn) -> int:
        """Number of cells seated in ``which`` (e.g. ``SeatedIn.ONLY_A``)."""
        return int(np.count_nonzero(self.seated_in == int(which)))

    def counts(self) -> dict[SeatedIn, int]:
        """Cells per :class:`SeatedIn` value; they add up to the grid's cell count."""
        return {w: self.count(w) for w in SeatedIn}


def map_difference(a: AcceptanceMapLike, b: AcceptanceMapLike) -> MapDifference:
    """Compare two maps node by node.

    Raises
    ------
    XfaceValueError
        A map is malformed (see :func:`~xface_core.viz.mapimage.checked_grid`) or the two
        do not share their grid: the same x0 and theta0 nodes (same grid size, theta grid
        and width D).

    Examples
    --------
    >>> from xface_core import v_face, x_face
    >>> from xface_core.maps.acceptance import acceptance_map
    >>> d = map_difference(
    ...     acceptance_map(x_face(0.25, 1.0), grid=11), acceptance_map(v_face(0.25, 1.0), grid=11)
    ... )
    >>> sum(d.counts().values()), d.count(SeatedIn.BOTH) + d.count(SeatedIn.ONLY_A) == d.M_a
    (121, True)
    """
    xa, ta, oa = checked_grid(a)
    xb, tb, ob = checked_grid(b)
    if not (np.array_equal(xa, xb) and np.array_equal(ta, tb)):
        raise XfaceValueError(
            "the two maps must share their grid (the same x0 and theta0 nodes: grid size, "
            f"theta grid and width); got {xa.size} x {ta.size} and {xb.size} x {tb.size} "
            "nodes" + (" on different axes" if oa.shape == ob.shape else "")
        )
    seated_a = oa == int(Outcome.SEATED)
    seated_b = ob == int(Outcome.SEATED)
    seated_in = seated_a.astype(np.int64) * int(SeatedIn.ONLY_A) + seated_b.astype(np.int64) * int(
        SeatedIn.ONLY_B
    )
    return MapDifference(
        seated_in=seated_in,
        M_a=int(np.count_nonzero(seated_a)),
        M_b=int(np.count_nonzero(seated_b)),
        same_outcome=int(np.count_nonzero(oa == ob)),
    )
