"""The paper's closed-form "best case" bounds for the V- and S-Face (Section III-B).

The paper did not simulate the V- and S-Faces: it counted the initial conditions that pass
two necessary conditions, "beyond which they will certainly fail", and printed the counts as
Tables III and IV. These bounds are kept apart from xface's simulation on purpose: they are
what the paper computed, not physics.

A *lever rule* marks a grid node (x0, theta0) as seated-bound when all three strict
inequalities hold (lengths in units of the face width D, ``h = H/D``)::

    |theta0|                      < pi/2 - atan(edge_slope * h)   angle cut
    |x0 + lever * sin(theta0)|    < capture_half_width            the tip lands in the mate
    |x0|                          < r_p + h/2                     reach, as the paper's code

with ``lever = lever_r * r_p + lever_h * h + lever_c``. The angle cut is the paper's
``|theta0| < pi/2 - |alpha_e|`` with ``alpha_e`` the angle of the contacted edge's normal;
the second line is its ``|x_tip| < D/2`` for the path of the moving tip.

- V-Face (:data:`V_RULE`): ``edge_slope = 2`` (the V flank), half-width 1/2 and lever
  ``(r_p + h)/2``. On the paper's theta grid this reproduces Table III in all 121 cells, and
  only on that grid.
- S-Face (:data:`S_RULE`): no rule of this kind reproduces Table IV (``docs/bounds.md`` and
  ``scripts/evidence/search_s_rule.py`` give the evidence). The cut ``atan(1.5 h)`` (the outer S
  segment) and the capture half-width 1/3 are pinned by the table's structure; the lever
  ``0.512 r_p + 0.662 h - 0.025`` is the best fit found that keeps the cells the cut and
  reach decide alone, and matches 34 of the 99 printed cells (sum of |dM| 294). That is no
  better than the same fit achieves on a deliberately perturbed Table IV, so it is a
  description, not a recovery of the paper's rule. :data:`S_RULE_ANALOGUE` is the direct
  analogue of the V rule, lever ``(r_p + h)/2`` (16 cells, sum of |dM| 516).

The lever and the reach are half of what the geometry of MODEL.md gives (tip lever
``r_p + h``, reach ``2 r_p + h``); that is what the paper's tables require.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Final, Literal

import numpy as np
import numpy.typing as npt

from xface_core.errors import XfaceValueError
from xface_core.geometry import MAX_DESIGN_RATIO

from .grids import PAPER_GRID_SIZE, PAPER_H_OVER_D, PAPER_R_P, ThetaGridKind, theta_grid, x0_grid

__all__ = [
    "S_RULE",
    "S_RULE_ANALOGUE",
    "V_RULE",
    "BoundFace",
    "LeverBoundRule",
    "bound_m",
    "bound_map",
    "bound_table",
    "lever_bound_map",
    "lever_bound_table",
]

BoundFace = Literal["V", "S"]
FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]


@dataclass(frozen=True)
class LeverBoundRule:
    """Parameters of a closed-form lever bound (see the module docstring).

    Attributes
    ----------
    edge_slope : float
        The contacted edge rises ``edge_slope * H`` per unit D; the angle cut is
        ``pi/2 - atan(edge_slope * h)``.
    capture_half_width : float
        Half-width of the band the tip must land in, in units of D.
    lever_r, lever_h, lever_c : float
        Tip lever ``lever_r * r_p + lever_h * h + lever_c``, in units of D.
    """

    edge_slope: float
    capture_half_width: float
    lever_r: float
    lever_h: float
    lever_c: float = 0.0

    def lever(self, h_over_d: float, r_p: float) -> float:
        """The tip lever for one design, in units of D.

        Examples
        --------
        >>> V_RULE.lever(1.0, 2.0)
        1.5
        """
        return self.lever_r * r_p + self.lever_h * h_over_d + self.lever_c


#: Reproduces Table III (V-Face) in all 121 cells on the paper's theta grid.
V_RULE: Final = LeverBoundRule(edge_slope=2.0, capture_half_width=0.5, lever_r=0.5, lever_h=0.5)
#: Best rule found for Table IV (S-Face): 34 of 99 cells, sum |dM| = 294 (a fit, see docs).
S_RULE: Final = LeverBoundRule(
    edge_slope=1.5, capture_half_width=1.0 / 3.0, lever_r=0.512, lever_h=0.662, lever_c=-0.025
)
#: The V rule carried over to the S geometry unchanged (lever (r_p + h)/2): 16 of 99 cells.
S_RULE_ANALOGUE: Final = LeverBoundRule(
    edge_slope=1.5, capture_half_width=1.0 / 3.0, lever_r=0.5, lever_h=0.5
)

_RULES: Final[dict[str, LeverBoundRule]] = {"V": V_RULE, "S": S_RULE}


def _rule_for(face: str) -> LeverBoundRule:
    if face not in _RULES:
        raise XfaceValueError(
            f"face must be 'V' or 'S' (the paper bounds only these; the X-Face is simulated), "
            f"got {face!r}"
        )
    return _RULES[face]


def _check_design(h_over_d: float, r_p: float) -> tuple[float, float]:
    values = []
    for name, value, allow_zero in (("h_over_d", h_over_d, False), ("r_p", r_p, True)):
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise XfaceValueError(f"{name} must be a real number, got {value!r}") from None
        if not math.isfinite(v):
            raise XfaceValueError(f"{name} must be finite, got {v!r}")
        if v < 0.0 or (v == 0.0 and not allow_zero):
            raise XfaceValueError(f"{name} must be {'>= 0' if allow_zero else '> 0'}, got {v!r}")
        if v > MAX_DESIGN_RATIO:
            raise XfaceValueError(
                f"{name} must be <= {MAX_DESIGN_RATIO:g} (the range the engine is verified "
                f"over; docs/model.md, Range), got {v!r}"
            )
        values.append(v)
    return values[0], values[1]


def _design_scalars(
    rule: LeverBoundRule, h_over_d: float, r_p: float
) -> tuple[float, float, float]:
    """(angle cut in rad, lever, reach), all computed with scalar math so that a map and a
    table cell evaluate bit-identical thresholds."""
    cut = math.pi / 2 - math.atan(rule.edge_slope * h_over_d)
    return cut, rule.lever(h_over_d, r_p), r_p + h_over_d / 2


def _seated_bound(
    x0: FloatArray,
    theta: FloatArray,
    *,
    sin_theta: FloatArray,
    cut: FloatArray | float,
    lever: FloatArray | float,
    reach: FloatArray | float,
    half_width: float,
) -> BoolArray:
    """The three strict inequalities, broadcast over whatever shapes the caller lines up."""
    tip = np.abs(x0 + lever * sin_theta)
    return (np.abs(theta) < cut) & (tip < half_width) & (np.abs(x0) < reach)


def lever_bound_map(
    rule: LeverBoundRule,
    h_over_d: float,
    r_p: float,
    *,
    theta_grid_kind: ThetaGridKind = "paper",
    n: int = PAPER_GRID_SIZE,
) -> BoolArray:
    """Seated-bound map of any :class:`LeverBoundRule` (research entry point).

    Same as :func:`bound_map` with an explicit rule.

    Examples
    --------
    >>> int(lever_bound_map(S_RULE_ANALOGUE, 0.0625, 10.0).sum())
    75
    """
    h, r = _check_design(h_over_d, r_p)
    x0 = x0_grid(n)[:, None]
    theta = theta_grid(n, theta_grid_kind)
    cut, lever, reach = _design_scalars(rule, h, r)
    return _seated_bound(
        x0,
        theta[None, :],
        sin_theta=np.sin(theta)[None, :],
        cut=cut,
        lever=lever,
        reach=reach,
        half_width=rule.capture_half_width,
    )


def bound_map(
    face: BoundFace,
    h_over_d: float,
    r_p: float,
    *,
    theta_grid: ThetaGridKind = "paper",
    n: int = PAPER_GRID_SIZE,
) -> BoolArray:
    """The paper's best-case bound as a map over the grid of initial conditions.

    Parameters
    ----------
    face : {"V", "S"}
        V-Face (Table III, exact) or S-Face (Table IV, best rule found; see module docs).
    h_over_d : float
        Profile height over width, H/D > 0.
    r_p : float
        Pivot distance from the profile base, in widths D, >= 0.
    theta_grid : {"paper", "symmetric"}, default "paper"
        The theta0 grid (:func:`xface_core.maps.grids.theta_grid`); "paper" reproduces the tables.
    n : int, default 41
        Nodes per axis (odd).

    Returns
    -------
    numpy.ndarray
        Bool, shape ``(n, n)``: rows x0 from -D to D, columns theta0 from -pi/2 to pi/2; True
        where the node passes the bound ("not certain to fail").

    Raises
    ------
    XfaceValueError
        Unknown face or grid kind, even or too small ``n``, or a design parameter that is
        NaN, infinite, negative (or zero for H/D) or above
        :data:`~xface_core.geometry.MAX_DESIGN_RATIO` (50).

    Examples
    --------
    >>> m = bound_map("V", 16.0, 3.0)
    >>> m.shape, int(m.sum())
    ((41, 41), 19)
    >>> bool(m[20, 20])  # aligned start at x0 = 0 passes
    True
    """
    rule = _rule_for(face)
    return lever_bound_map(rule, h_over_d, r_p, theta_grid_kind=theta_grid, n=n)


def bound_m(
    face: BoundFace,
    h_over_d: float,
    r_p: float,
    *,
    theta_grid: ThetaGridKind = "paper",
    n: int = PAPER_GRID_SIZE,
) -> int:
    """The paper's metric M for the bound: the number of True nodes of :func:`bound_map`.

    Examples
    --------
    >>> bound_m("V", 0.0625, 1.0)  # Table III, first row, r_p = 1
    739
    """
    return int(bound_map(face, h_over_d, r_p, theta_grid=theta_grid, n=n).sum())


def lever_bound_table(
    rule: LeverBoundRule,
    h_over_d: Sequence[float] = PAPER_H_OVER_D,
    r_p: Sequence[float] = PAPER_R_P,
    *,
    theta_grid_kind: ThetaGridKind = "paper",
    n: int = PAPER_GRID_SIZE,
) -> IntArray:
    """M of any :class:`LeverBoundRule` over a table of designs (research entry point).

    Examples
    --------
    >>> int(lever_bound_table(S_RULE_ANALOGUE)[0, 10])
    75
    """
    designs = [[_check_design(h, r) for r in r_p] for h in h_over_d]
    if not designs or not designs[0]:
        raise XfaceValueError("h_over_d and r_p must each hold at least one value")
    scalars = np.array(
        [[_design_scalars(rule, h, r) for h, r in row] for row in designs], dtype=np.float64
    )  # (n_h, n_r, 3)
    x0 = x0_grid(n)[None, None, :, None]
    theta = theta_grid(n, theta_grid_kind)
    seated = _seated_bound(
        x0,
        theta[None, None, None, :],
        sin_theta=np.sin(theta)[None, None, None, :],
        cut=scalars[:, :, 0, None, None],
        lever=scalars[:, :, 1, None, None],
        reach=scalars[:, :, 2, None, None],
        half_width=rule.capture_half_width,
    )
    return np.asarray(seated.sum(axis=(2, 3)), dtype=np.int64)


def bound_table(
    face: BoundFace,
    *,
    theta_grid: ThetaGridKind = "paper",
    h_over_d: Sequence[float] = PAPER_H_OVER_D,
    r_p: Sequence[float] = PAPER_R_P,
    n: int = PAPER_GRID_SIZE,
) -> IntArray:
    """The bound's M over the paper's design table (rows H/D, columns r_p), vectorised.

    Each cell equals :func:`bound_m` for that design, to the node.

    Parameters
    ----------
    face : {"V", "S"}
    theta_grid : {"paper", "symmetric"}, default "paper"
    h_over_d, r_p : sequence of float
        Row and column keys; default the paper's 11 x 11 design space.
    n : int, default 41

    Returns
    -------
    numpy.ndarray
        int64, shape ``(len(h_over_d), len(r_p))``.

    Examples
    --------
    >>> from xface_core.maps.paper import paper_table
    >>> bool((bound_table("V") == paper_table("V").M).all())
    True
    >>> int(bound_table("S")[0, 0])  # Table IV prints 38
    38
    """
    rule = _rule_for(face)
    return lever_bound_table(rule, h_over_d, r_p, theta_grid_kind=theta_grid, n=n)
