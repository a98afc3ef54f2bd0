"""The engine's artefacts that --converged controls beyond the step: creeps taken for jams,
and knife-edge cells (docs/crosscheck.md)."""

from __future__ import annotations

import math

import xface_core as xf
from xface_core import Outcome
from xface_core.crosscheck import crosscheck
from xface_core.crosscheck.compare import confirm_stalls, engine_map


def test_a_creep_near_a_fold_is_no_jam() -> None:
    # S H/D 0.32988 r_p 2 at x0 = 0.7, theta0 = -pi/10 enters a two-contact path 2.4e-7 D
    # below its fold's top: the pivot creeps at about 1e-6 of its free speed and stalls the
    # default test; at 1/100 of the stall speed the engine seats, as xface does.
    design = xf.s_face(0.32988, 2.0)
    cell = [(0.7, -math.pi / 10)]
    em = engine_map(design, cells=cell, workers=1)
    assert em.sharp[0].outcome is Outcome.BAD_MATE
    confirmed = confirm_stalls(design, em, workers=1)
    assert confirmed.sharp[0].outcome is Outcome.SEATED
    assert confirmed.stall_changes == 1


def test_a_disagreement_on_a_knife_edge_is_ambiguous() -> None:
    # V H/D 0.57435 r_p 1 at x0 = -D/2, theta0 = 0: the V tip lands exactly on the notch's
    # corner; BAD_MATE just left of it and SEATED just right, in xface and the sharp engine,
    # which picks BAD_MATE at the tie (xface SEATED). Not a property of the design.
    r = crosscheck(xf.v_face(0.57435, 1.0), cells=[(-0.5, 0.0)], converged=True, workers=1)
    assert r.knife_edges == 1
    assert r.ambiguous.tolist() == [True]
    assert r.disagreements == ()
