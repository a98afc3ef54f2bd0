"""interval.py: the run's start, the exact approach, the contacts chosen at an interval."""

from __future__ import annotations

import math

import numpy as np
import pytest

import xface_core as xf
from xface_core._engine.interval import approach, begin_interval, start_run
from xface_core._engine.pairs import eval_all_pairs, fill_u_rate, next_contact, pair_at
from xface_core._engine.records import (
    O_BAD_MATE,
    O_NO_CONTACT,
    O_PASSED,
    O_SEATED,
    O_UNRESOLVED,
    P_APPROACH,
    R_BELOW_SEAT,
    R_EVENT_LIMIT,
    R_NO_CONTACT,
    R_PASSED,
    R_SEATED,
    RUN_DTYPE,
    UNDECIDED,
    make_options,
    new_work,
)
from xface_core.physics import Physics
from xface_core.runner import engine_model, start_height

DESIGN = xf.x_face(0.5, 2.0)  # L = 4.5
MODEL = engine_model(DESIGN)
OPTS = make_options(Physics())


class Run:
    """One run's record, work and path buffers, started at a pose."""

    def __init__(self, x0: float, theta0: float, y: float | None = None) -> None:
        self.runs = np.zeros(1, dtype=RUN_DTYPE)
        self.work = new_work(MODEL, OPTS)
        self.path = np.zeros((16, 4))
        self.pairs = np.zeros((16, 4), dtype=np.int64)
        self.y_start = start_height(DESIGN, theta0) if y is None else y
        start_run(MODEL, OPTS, x0, theta0, self.y_start, self.r, self.work, self.path, self.pairs)

    @property
    def r(self) -> np.void:
        return self.runs[0]

    def approach(self) -> None:
        """begin_interval (which evaluates every pair at the current state), then approach,
        as the stage loop calls them when nothing touches."""
        self.begin()
        assert self.r["n_active"] == 0
        approach(MODEL, OPTS, self.r, self.work, self.path, self.pairs)

    def begin(self) -> None:
        begin_interval(MODEL, OPTS, self.r, self.work, self.path, self.pairs)


def test_start_run_resets_the_run_to_the_start_pose() -> None:
    run = Run(0.3, 0.2)
    r = run.r
    assert (r["outcome"], r["phi_b"], r["phi_m"], r["y_m"], r["x0"]) == (
        UNDECIDED, 0.0, 0.2, run.y_start, 0.3,
    )  # fmt: skip
    assert (r["steps"], r["events"], r["n_active"], r["had_contact"]) == (0, 0, 0, False)
    assert r["h"] == OPTS.first_step
    assert r["n_samples"] == 1
    assert run.path[0].tolist() == [run.y_start, 0.0, 0.2, P_APPROACH]


def test_the_floor_is_the_seat_height_less_the_seat_tolerance() -> None:
    L, x0 = MODEL.mated_distance, 0.3
    assert Run(x0, 0.2).r["y_floor"] == math.sqrt(L * L - x0 * x0) - OPTS.seat_tol * L


def test_approach_translates_exactly_to_the_next_contact() -> None:
    run = Run(0.3, 0.2)
    ev = np.zeros((len(MODEL.pairs), 6))
    eval_all_pairs(MODEL.pairs, 0.0, 0.2, 0.3, run.y_start, ev)
    fill_u_rate(MODEL.pairs, 0.0, 0.2, ev)
    d, i = next_contact(ev, OPTS.touch_tol)
    run.approach()
    r = run.r
    assert r["y_m"] == run.y_start - d
    assert (r["phi_b"], r["phi_m"]) == (0.0, 0.2)  # angles frozen
    assert (r["events"], r["had_contact"], r["n_samples"]) == (1, True, 2)
    assert pair_at(MODEL.pairs, i, 0.0, 0.2, 0.3, r["y_m"])[0] == pytest.approx(0.0, abs=1e-12)


def test_approach_beside_the_base_never_touches() -> None:
    run = Run(1.5, 0.0)  # the moving body spans x in [1, 2], the base [-0.5, 0.5]
    run.approach()
    assert (run.r["outcome"], run.r["reason"]) == (O_NO_CONTACT, R_NO_CONTACT)


def test_approach_after_a_contact_with_nothing_ahead_has_passed() -> None:
    run = Run(1.5, 0.0)
    run.r["had_contact"] = True
    run.approach()
    assert (run.r["outcome"], run.r["reason"]) == (O_PASSED, R_PASSED)


def test_approach_to_a_contact_below_the_floor_stops_at_the_floor() -> None:
    run = Run(0.3, 0.2)
    run.r["y_floor"] = run.y_start - 1e-3
    run.approach()
    assert (run.r["outcome"], run.r["reason"]) == (O_BAD_MATE, R_BELOW_SEAT)
    assert run.r["y_m"] == run.y_start - 1e-3


def test_begin_interval_at_a_first_contact_activates_it() -> None:
    run = Run(0.3, 0.2)
    run.approach()
    run.begin()
    r = run.r
    assert r["outcome"] == UNDECIDED
    assert r["n_active"] >= 1
    assert r["contact_changes"] == 1
    for i in run.work.act[: r["n_active"]]:
        assert abs(pair_at(MODEL.pairs, int(i), 0.0, 0.2, 0.3, r["y_m"])[0]) <= OPTS.touch_tol


def test_begin_interval_with_the_event_budget_spent_is_unresolved() -> None:
    run = Run(0.3, 0.2)
    run.r["events"] = OPTS.max_events
    run.begin()
    assert (run.r["outcome"], run.r["reason"]) == (O_UNRESOLVED, R_EVENT_LIMIT)


def test_begin_interval_at_the_mated_pose_after_a_contact_is_seated() -> None:
    L, phi = MODEL.mated_distance, 0.1
    run = Run(-L * math.sin(phi), phi)
    r = run.r
    r["phi_b"], r["y_m"], r["had_contact"] = phi, L * math.cos(phi), True
    run.begin()
    assert (r["outcome"], r["reason"]) == (O_SEATED, R_SEATED)


def _asleep_far_pairs(run: Run, far: float) -> np.ndarray:
    """Mark the pairs farther than ``far`` (D) from their edge line as asleep through the
    last scanned step, as an event's step leaves them; returns the mask."""
    r = run.r
    ev = np.zeros((len(MODEL.pairs), 6))
    eval_all_pairs(MODEL.pairs, r["phi_b"], r["phi_m"], r["x0"], r["y_m"], ev)
    mask = np.abs(ev[:, 0]) > far
    run.work.sleep[mask, 1] = 0.01
    run.work.sleep_holds[0] = 1
    return mask


def test_begin_interval_after_an_event_evaluates_only_the_pairs_in_reach() -> None:
    # The same state twice: every pair evaluated, or those asleep through the event's step
    # left out. The choice is the same; the left-out pairs are no candidates.
    full, kept = Run(0.3, 0.2), Run(0.3, 0.2)
    full.approach()
    kept.approach()
    mask = _asleep_far_pairs(kept, 0.05)
    assert 0 < mask.sum() < len(mask)
    full.begin()
    kept.begin()
    assert kept.r["n_active"] == full.r["n_active"] >= 1
    assert kept.work.act.tolist() == full.work.act.tolist()
    assert np.all(np.isinf(kept.work.ev[mask, 0]))
    assert np.array_equal(kept.work.ev[~mask, :5], full.work.ev[~mask, :5])


def test_begin_interval_evaluates_every_pair_when_an_excluded_one_slept() -> None:
    run = Run(0.3, 0.2)
    run.approach()
    mask = _asleep_far_pairs(run, 0.05)
    run.work.exclude[0] = int(np.flatnonzero(mask)[0])
    run.r["n_excluded"] = 1
    run.begin()
    assert np.all(np.isfinite(run.work.ev[:, 0]))
    assert run.work.sleep_holds[0] == 0


def test_an_approach_after_an_event_evaluates_every_pair_again() -> None:
    # Nothing touches at the start: begin_interval leaves the sleeping pairs out, and the
    # approach, which needs every pair's way to its contact, evaluates them all.
    full, kept = Run(0.3, 0.2), Run(0.3, 0.2)
    assert _asleep_far_pairs(kept, -1.0).all()  # the pair it will touch among them
    full.approach()
    kept.approach()
    assert kept.r["y_m"] == full.r["y_m"]
    assert kept.work.sleep_holds[0] == 0
