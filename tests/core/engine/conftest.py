"""Hand-built cases shared by the unit tests of the engine's stages (units of D, rad).

The main case, :class:`Incline`, is a moving vertex sliding down a straight base edge while
the base is held (``winv_b = 0``): one contact, one degree of freedom, so the path has a
closed form (the vertex stays on the edge's line, ``g(phi_M, y_M) = 0``) that the tests
solve for by bisection, independently of the engine's integrator.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pytest

import xface_core as xf
from xface_core._engine.pairs import fill_extents, pair_at
from xface_core._engine.records import (
    DENSE_WIDTH,
    FREE,
    STEP_MEMO_SLOTS,
    STEP_MEMO_WIDTH,
    Contacts,
    Segment,
    Step,
)
from xface_core.contact import pair_table

#: Columns of the engine's pair table; hand-built rows fill the first ten (kind, vertex, edge,
#: normal, layer) and leave any further ones zero.
TABLE_WIDTH = pair_table(xf.v_face(0.5, 1.0)).data.shape[1]


def bisect(f: Callable[[float], float], lo: float, hi: float) -> float:
    """Root of f in [lo, hi] (f must change sign there) to the last bit."""
    f_lo = f(lo)
    assert (f_lo > 0.0) != (f(hi) > 0.0), "no sign change in the bracket"
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            break
        f_mid = f(mid)
        if (f_mid > 0.0) == (f_lo > 0.0):
            lo, f_lo = mid, f_mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


@dataclass(frozen=True)
class Incline:
    """Pair 0: moving vertex (0.3, 1.2) on the base edge from (0.5, 1.5) down to (-0.5, 1.0)
    (slope 1/2, outside up and to the left), base held. Pair 1: moving vertex (-0.4, 1.3)
    above a flat base edge placed so that the path of pair 0 brings it down onto that edge
    exactly at the descent ``s_touch``.

    The run starts at ``phi_m0`` with pair 0 touching, at height ``y0``.
    """

    table: np.ndarray
    x0: float
    phi_m0: float
    y0: float
    s_touch: float

    def gap(self, i: int, pm: float, ym: float, pb: float = 0.0) -> float:
        return float(pair_at(self.table, i, pb, pm, self.x0, ym)[0])

    def phi_m_at(self, s: float) -> float:
        """The exact angle of the moving part after a descent s: pair 0 stays on its line."""
        return bisect(
            lambda pm: self.gap(0, pm, self.y0 - s), self.phi_m0 - 0.3, self.phi_m0 + 0.05
        )

    def segment(
        self, *, n_active: int = 1, y_floor: float = -math.inf, winv_b: float = 0.0,
        mu: float = 0.0, slip: np.ndarray | None = None,
    ) -> Segment:  # fmt: skip
        """The smooth segment with pair 0 active (and pair 1 too for ``n_active=2``), with
        Coulomb coefficient ``mu`` and friction states ``slip`` (default: both free)."""
        act = np.array([0, 1, -1, -1][:n_active] + [-1] * (4 - n_active), dtype=np.int64)
        if slip is None:
            slip = np.full(2, FREE, dtype=np.int64)
        held = Contacts(self.table, act, n_active, mu, slip, self.x0, math.sqrt(winv_b), 1.0,
                        winv_b, 1.0)  # fmt: skip
        return Segment(
            held, y_floor, np.zeros((STEP_MEMO_SLOTS + 1, STEP_MEMO_WIDTH)),
            np.zeros((2, DENSE_WIDTH)),
        )  # fmt: skip

    def step(self, h: float) -> Step:
        return Step(0.0, self.phi_m0, self.y0, h)


def _incline() -> Incline:
    x0, phi_m0, s_touch = 0.2, 0.1, 0.0123
    # Rows: kind (0: moving vertex), vertex, edge start and end, outward normal, layer.
    up_left = (-1.0 / math.sqrt(5.0), 2.0 / math.sqrt(5.0))
    slope = np.array([0.0, 0.3, 1.2, 0.5, 1.5, -0.5, 1.0, *up_left, 0.0])
    # Where pair 0 touches at phi_m0: the gap is linear in y_M with slope beta = n_y.
    g_ref, _, _, _, beta, _, _, _, _ = pair_at(slope[None, :], 0, 0.0, phi_m0, x0, 3.0)
    y0 = 3.0 - g_ref / beta
    probe = Incline(slope[None, :].copy(), x0, phi_m0, y0, s_touch)
    # The second vertex's height at s_touch on the exact path sets the flat edge's height.
    pm = probe.phi_m_at(s_touch)
    vx, vy = -0.4, 1.3
    height = y0 - s_touch - (math.sin(pm) * vx + math.cos(pm) * vy)
    flat = np.array([0.0, vx, vy, 1.5, height, -1.5, height, 0.0, 1.0, 0.0])
    table = np.zeros((2, TABLE_WIDTH))
    table[:, :10] = (slope, flat)
    fill_extents(table)
    return Incline(table, x0, phi_m0, y0, s_touch)


@pytest.fixture(scope="session")
def incline() -> Incline:
    return _incline()
