"""Grids of initial conditions (x0, theta0) and the paper's design-parameter axes.

The paper counts successes M over 41 x 41 initial conditions: the lateral offset x0 from -D
to D and the initial angle theta0 from -pi/2 to pi/2 (Section IV). Every grid here is built
from integers, so a mirrored pair of nodes is exact to the bit: ``x0[n - 1 - i] == -x0[i]``
(``np.linspace(-1, 1, 41)`` does not have this property, and mirror-symmetry tests of
acceptance maps need it).

Two theta grids exist:

- ``"symmetric"``: ``theta0 = k pi / (2 h)`` for ``k = -h..h`` with ``h = (n - 1) / 2``
  (``k pi / 40`` for ``n = 41``). This is xface's own default.
- ``"paper"``: the asymmetric grid the paper's tables were computed on, recovered from
  Table III (see ``docs/bounds.md``): ``k pi / (2 h)`` for ``k = -h..0`` and
  ``(k - 1/2) pi / (2 h)`` for ``k = 1..h``. Its positive half is shifted by half a step, so
  it includes ``-pi/2`` but stops at ``(h - 1/2) pi / (2 h)`` on the positive side.
"""

from __future__ import annotations

import math
import operator
from typing import Final, Literal

import numpy as np
import numpy.typing as npt

from xface_core.errors import XfaceValueError

__all__ = [
    "PAPER_GRID_SIZE",
    "PAPER_H_OVER_D",
    "PAPER_R_P",
    "ThetaGridKind",
    "paper_h_over_d_exact",
    "theta_grid",
    "x0_grid",
]

FloatArray = npt.NDArray[np.float64]
ThetaGridKind = Literal["symmetric", "paper"]

#: Nodes per axis of the paper's grid (41 x 41 = 1681 initial conditions).
PAPER_GRID_SIZE: Final = 41

#: The H/D row keys of Tables II-IV exactly as the paper prints them. They follow
#: ``H/D = 16 ** ((i - 5) / 5) = 2 ** (0.8 i - 4)`` for ``i = 0..10`` (a geometric series from
#: 1/16 to 16, ratio 2**0.8), rounded to five significant digits; see
#: :func:`paper_h_over_d_exact`. The bounds of Tables III and IV are reproduced with these
#: printed values.
PAPER_H_OVER_D: Final[tuple[float, ...]] = (
    0.0625,
    0.10882,
    0.18946,
    0.32988,
    0.57435,
    1.0,
    1.7411,
    3.0314,
    5.278,
    9.1896,
    16.0,
)

#: The r_p column keys of Tables II-IV: pivot distance from the profile base, in widths D.
PAPER_R_P: Final[tuple[float, ...]] = tuple(float(r) for r in range(11))


#: The largest grid, nodes per axis: 1001 x 1001 is a million simulations (about 15 s for a
#: map on two cores); beyond it a map's arrays alone grow past what a workstation holds
#: (100 001 nodes per axis asked for 74.5 GiB), so a larger grid is refused up front.
MAX_GRID_SIZE: Final[int] = 1001


def _half_count(n: int) -> int:
    """Validate a grid size and return ``(n - 1) // 2``."""
    if isinstance(n, bool):
        raise XfaceValueError(f"grid size must be an odd integer >= 3, got {n!r}")
    try:
        size = operator.index(n)
    except TypeError:
        raise XfaceValueError(f"grid size must be an odd integer >= 3, got {n!r}") from None
    if size < 3 or size % 2 == 0:
        raise XfaceValueError(f"grid size must be an odd integer >= 3, got {size}")
    if size > MAX_GRID_SIZE:
        # The map's pose arrays and results take about 40 bytes per node (x0, theta0, start
        # height, outcome, angles) before a single simulation runs.
        gib = 40.0 * size * size / 2**30
        raise XfaceValueError(
            f"grid size {size} is {size * size:.3g} simulations and about {gib:.3g} GiB of "
            f"arrays; the largest grid is {MAX_GRID_SIZE} nodes per axis"
        )
    return (size - 1) // 2


def x0_grid(n: int = PAPER_GRID_SIZE) -> FloatArray:
    """Lateral offsets x0 from -D to D, both ends included, in units of D.

    ``x0 = i / h`` for the integers ``i = -h..h``, ``h = (n - 1) / 2``. Because each node is
    one correctly rounded division of an exact integer, ``x0[n - 1 - i] == -x0[i]`` bit for
    bit and the centre node is exactly 0.

    Parameters
    ----------
    n : int, default 41
        Number of nodes; an odd integer >= 3.

    Returns
    -------
    numpy.ndarray
        Shape ``(n,)``, float64, increasing, in units of the face width D.

    Raises
    ------
    XfaceValueError
        If ``n`` is not an odd integer >= 3.

    Examples
    --------
    >>> g = x0_grid()
    >>> g.shape, float(g[0]), float(g[20]), float(g[-1]), float(g[21])
    ((41,), -1.0, 0.0, 1.0, 0.05)
    >>> bool((g[::-1] == -g).all())
    True
    """
    half = _half_count(n)
    i = np.arange(-half, half + 1, dtype=np.int64)
    return i / half


def theta_grid(n: int = PAPER_GRID_SIZE, kind: ThetaGridKind = "symmetric") -> FloatArray:
    """Initial angles theta0 over [-pi/2, pi/2], in radians.

    Parameters
    ----------
    n : int, default 41
        Number of nodes; an odd integer >= 3.
    kind : {"symmetric", "paper"}, default "symmetric"
        ``"symmetric"``: ``k pi / (2 h)`` for ``k = -h..h`` (``h = (n - 1) / 2``); the grid is
        mirror-symmetric to the bit (``theta[n - 1 - k] == -theta[k]``) and includes both
        ends. ``"paper"``: ``k pi / (2 h)`` for ``k = -h..0`` and ``(k - 1/2) pi / (2 h)`` for
        ``k = 1..h``, the asymmetric grid on which the paper computed Tables III and IV.

    Returns
    -------
    numpy.ndarray
        Shape ``(n,)``, float64, strictly increasing, radians.

    Raises
    ------
    XfaceValueError
        If ``n`` is not an odd integer >= 3 or ``kind`` is unknown.

    Examples
    --------
    >>> import math
    >>> t = theta_grid()
    >>> float(t[0]) == -math.pi / 2, float(t[-1]) == math.pi / 2, float(t[20])
    (True, True, 0.0)
    >>> p = theta_grid(kind="paper")
    >>> float(p[0]) == -math.pi / 2, float(p[21]) == math.pi / 80
    (True, True)
    >>> bool(p[-1] < math.pi / 2)
    True
    """
    half = _half_count(n)
    k = np.arange(-half, half + 1, dtype=np.int64)
    if kind == "symmetric":
        # (k * pi) is exact in sign, and dividing by the same positive number keeps the
        # mirror pair exact: theta[-k] == -theta[k] to the bit.
        return (k * math.pi) / (2 * half)
    if kind == "paper":
        # Half-integer steps are exact in binary, so only one rounding per node here too.
        steps = np.where(k <= 0, k.astype(np.float64), k - 0.5)
        return (steps * math.pi) / (2 * half)
    raise XfaceValueError(f"theta grid kind must be 'symmetric' or 'paper', got {kind!r}")


def paper_h_over_d_exact() -> FloatArray:
    """The unrounded H/D series behind :data:`PAPER_H_OVER_D`: ``16 ** ((i - 5) / 5)``.

    Returns
    -------
    numpy.ndarray
        Shape ``(11,)``, from 1/16 to 16, ratio ``2 ** 0.8`` between neighbours.

    Examples
    --------
    >>> exact = paper_h_over_d_exact()
    >>> [float(f"{v:.5g}") for v in exact] == list(PAPER_H_OVER_D)
    True
    """
    i = np.arange(11, dtype=np.float64)
    return np.asarray(16.0 ** ((i - 5.0) / 5.0), dtype=np.float64)
