"""Two acceptance maps of the same grid compared cell by cell: where each one seats.

The grids are compared in units of D, the unit the maps are built on (x0 from -D to D,
:func:`~xface_core.maps.acceptance.acceptance_map`): a design of width 0.05 and one of width 1
are compared at the same x0 / D. The engine runs in D and the width only scales poses in and
out, so a map's outcomes do not depend on its width; two designs that differ only in D seat at
the same x0 / D and differ by D at the same x0.

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
from xface_core.geometry import FaceDesign
from xface_core.viz.mapgrid import AcceptanceMapLike, checked_grid

__all__ = ["MapDifference", "SeatedIn", "in_units_of_d", "map_difference", "same_nodes_in_d"]

#: Two x0 nodes in units of D are the same node when this close: a grid's nodes are
#: ``i / h`` times the width, so dividing by the width again leaves at most a few ulps, and
#: the finest grid (1001 nodes) has nodes 2e-3 D apart.
NODE_TOLERANCE_D = 1e-9


def same_nodes_in_d(a: AcceptanceMapLike, b: AcceptanceMapLike) -> bool:
    """Whether the x0 nodes of ``a`` and ``b`` are the same in units of each map's own D."""
    xa = np.asarray(a.x0, dtype=np.float64) / a.design.width
    xb = np.asarray(b.x0, dtype=np.float64) / b.design.width
    return xa.shape == xb.shape and bool(np.all(np.abs(xa - xb) <= NODE_TOLERANCE_D))


@dataclass(frozen=True)
class _MapInD:
    """A map's outcomes and regions with x0 in units of D (its design at width 1)."""

    design: FaceDesign
    x0: npt.NDArray[np.float64]
    theta0: npt.NDArray[np.float64]
    outcomes: npt.NDArray[np.int8]
    M: int
    guaranteed: object
    centred: object


def in_units_of_d(amap: AcceptanceMapLike) -> AcceptanceMapLike:
    """``amap`` with x0 in units of D (the same cells; a width-1 design): what a picture of
    two designs of different widths draws, both on one axis."""
    if amap.design.width == 1.0:
        return amap
    return _MapInD(
        design=amap.design.with_width(1.0),
        x0=np.asarray(amap.x0, dtype=np.float64) / amap.design.width,
        theta0=np.asarray(amap.theta0, dtype=np.float64),
        outcomes=np.asarray(amap.outcomes),
        M=int(amap.M),
        guaranteed=amap.guaranteed,
        centred=getattr(amap, "centred", None),
    )


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
        do not share their grid: the same x0 / D and theta0 nodes (same grid size and theta
        grid; the widths D may differ).

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
    if not (same_nodes_in_d(a, b) and np.array_equal(ta, tb)):
        raise XfaceValueError(
            "the two maps must share their grid (the same x0 / D and theta0 nodes: grid size "
            f"and theta grid); got {xa.size} x {ta.size} and {xb.size} x {tb.size} "
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
