"""Margins: the distance to the nearest outcome flip along each axis."""

from __future__ import annotations

import math

import numpy as np
import pytest

import xface_core as xf
from xface_core.atlas import margins
from xface_core.atlas.margins import ANGLE_RESOLUTION, LATERAL_RESOLUTION


def test_lateral_margin_brackets_a_flip() -> None:
    design = xf.x_face(0.25, 2.0)
    p = xf.predict(design, 0.3, 0.2, margins=True)
    m = p.margins
    assert m is not None
    inside = xf.predict(design, 0.3 + m.lateral_plus - 2 * LATERAL_RESOLUTION, 0.2, path=False)
    outside = xf.predict(design, 0.3 + m.lateral_plus, 0.2, path=False)
    assert inside.outcome is p.outcome
    assert outside.outcome is not p.outcome


def test_angle_margin_brackets_a_flip() -> None:
    design = xf.v_face(0.5, 1.0)
    p = xf.predict(design, 0.1, 0.05, margins=True)
    m = p.margins
    assert m is not None
    inside = xf.predict(design, 0.1, 0.05 - m.angle_minus + 2 * ANGLE_RESOLUTION, path=False)
    outside = xf.predict(design, 0.1, 0.05 - m.angle_minus, path=False)
    assert inside.outcome is p.outcome
    assert outside.outcome is not p.outcome


def test_out_of_reach_pose_has_finite_lateral_margin() -> None:
    design = xf.x_face(0.25, 0.0)  # L = 0.25
    p = xf.predict(design, 0.5, 0.0, margins=True)
    assert p.margins is not None
    assert p.margins.lateral_minus <= 0.25 + LATERAL_RESOLUTION


def test_margins_are_searched_at_the_query_start_height() -> None:
    # A start below the base never touches (NO_CONTACT); its neighbours started there do
    # not either, so no flip lies within a scan step (it was +-9.8e-5 D when the neighbours
    # were simulated from the default start instead).
    design = xf.x_face(0.25, 2.0)
    p = xf.predict(design, 0.3, 0.2, y_start=-5.0, path=False, margins=True)
    assert p.outcome is xf.Outcome.NO_CONTACT
    assert p.margins is not None
    assert min(p.margins.lateral, p.margins.angle) > 0.025


def test_batch_start_height_matches_predict() -> None:
    design = xf.v_face(0.5, 1.0)
    for y in (-3.0, 4.0):
        single = xf.predict(design, 0.1, 0.05, y_start=y, path=False).outcome
        batch = xf.predict_batch(design, [0.1], [0.05], y_start=y).outcome[0]
        assert batch == single


@pytest.mark.parametrize(("x0", "theta0"), [(2.6, 0.3), (-3.1, -1.2), (9.0, 0.0)])
def test_out_of_reach_margins_are_what_the_scan_finds(x0: float, theta0: float) -> None:
    # Beyond L every pose ends OUT_OF_REACH: the margins need no simulation, and equal the
    # exact scan's (run here without the shortcut) within its resolution.
    from xface_core.atlas.margins import ANGLE_STEP, LATERAL_STEP, flip_distance, reach_margins

    design = xf.x_face(0.25, 1.0, width=0.05)
    x = x0 * design.width
    outcome = xf.predict(design, x, theta0).outcome
    assert outcome == xf.Outcome.OUT_OF_REACH
    known = reach_margins(design, x, theta0, outcome)
    assert known is not None
    limits = (2.0 * design.mated_distance, math.pi)
    steps, res = (LATERAL_STEP, ANGLE_STEP), (1e-4, 1e-5)
    for axis, direction, got in (
        (0, -1.0, known.lateral_minus), (0, 1.0, known.lateral_plus),
        (1, -1.0, known.angle_minus), (1, 1.0, known.angle_plus),
    ):  # fmt: skip
        scanned = flip_distance(
            design, x, theta0, outcome, axis=axis, direction=direction, limit=limits[axis],
            step=steps[axis], resolution=res[axis], physics=xf.Physics(),
        )  # fmt: skip
        if math.isinf(scanned):
            assert math.isinf(got)
        else:
            scale = design.width if axis == 0 else 1.0
            assert -1e-12 <= scanned - got <= res[axis] * scale * (1 + 1e-9)


def test_reach_margins_leave_other_outcomes_to_the_search() -> None:
    from xface_core.atlas.margins import reach_margins

    design = xf.x_face(0.25, 1.0)
    assert reach_margins(design, 0.1, 0.0, xf.Outcome.SEATED) is None
    assert reach_margins(design, 3.0, 4.0, xf.Outcome.OUT_OF_REACH) is None  # |theta0| > pi


def test_a_miss_is_searched_by_its_approach_alone_with_the_same_margins(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from xface_core.atlas import margins as margins_module

    design = xf.x_face(0.25, 1.0)
    x0, theta0 = 1.5 * design.width, 0.3
    outcome = xf.predict(design, x0, theta0, path=False).outcome
    assert outcome is xf.Outcome.NO_CONTACT
    fast = margins_module.outcome_margins(design, x0, theta0, outcome)
    monkeypatch.setattr(margins_module, "search_physics", lambda d, physics, o, y: physics)
    assert margins_module.outcome_margins(design, x0, theta0, outcome) == fast


def test_only_a_miss_started_clear_of_the_base_is_searched_by_its_approach() -> None:
    from xface_core.atlas.margins import search_physics
    from xface_core.runner import clear_start_height

    design, physics = xf.x_face(0.25, 1.0), xf.Physics()
    clear = clear_start_height(design) * design.width
    assert search_physics(design, physics, xf.Outcome.NO_CONTACT, None).settings.max_events == 1
    assert search_physics(design, physics, xf.Outcome.NO_CONTACT, clear).settings.max_events == 1
    assert search_physics(design, physics, xf.Outcome.NO_CONTACT, 0.5 * clear) is physics
    assert search_physics(design, physics, xf.Outcome.SEATED, None) is physics


def _reference_flip(
    design: xf.FaceDesign, x0: float, theta0: float, outcome: xf.Outcome,
    half: margins.HalfAxisSearch, y_start: float | None,
) -> float:  # fmt: skip
    """The exact search of one half-axis written plainly, one batch or midpoint at a time
    through ``predict_batch`` (the algorithm before the half-axes ran in lockstep)."""
    scale = design.width if half.axis == 0 else 1.0
    n = max(1, math.ceil((half.limit - half.first) / half.step))
    offsets = half.first + np.arange(1, n + 1) * half.step

    def codes(off: np.ndarray) -> np.ndarray:
        xs = x0 + half.direction * off * scale if half.axis == 0 else np.full(off.shape, x0)
        ts = theta0 + half.direction * off if half.axis == 1 else np.full(off.shape, theta0)
        return xf.predict_batch(design, xs, ts, y_start=y_start).outcome

    for start in range(0, offsets.size, margins.SCAN_BATCH):
        found = np.flatnonzero(codes(offsets[start : start + margins.SCAN_BATCH]) != outcome)
        if found.size:
            hi = float(offsets[start + int(found[0])])
            lo = hi - half.step
            while hi - lo > half.resolution:
                mid = 0.5 * (lo + hi)
                if codes(np.array([mid]))[0] == outcome:
                    lo = mid
                else:
                    hi = mid
            return hi * scale
    return math.inf


@pytest.mark.parametrize(
    ("face", "x0", "theta0", "y_start"),
    [("X", 0.3, 0.2, None), ("V", -0.4, -0.3, None), ("S", 0.2, 0.1, 2.5), ("X", 1.5, 0.3, None)],
)
def test_half_axes_in_lockstep_find_what_each_finds_alone(
    face: str, x0: float, theta0: float, y_start: float | None
) -> None:
    design = xf.make_face(face, 1.0, 1.0)
    outcome = xf.predict(design, x0, theta0, y_start=y_start, path=False).outcome
    searches = [
        margins.HalfAxisSearch(0, -1.0, 2.0, margins.LATERAL_STEP, 1e-4),
        margins.HalfAxisSearch(0, 1.0, 2.0, 0.1, 1e-3, first=0.05),
        margins.HalfAxisSearch(1, -1.0, math.pi, margins.ANGLE_STEP, 1e-5),
        margins.HalfAxisSearch(1, 1.0, 0.3, 0.07, 1e-5, first=0.01),
    ]
    together = margins.flip_distances(
        design, x0, theta0, outcome, searches, physics=xf.Physics(), y_start=y_start
    )
    alone = [_reference_flip(design, x0, theta0, outcome, s, y_start) for s in searches]
    assert together == alone


def test_an_exact_search_takes_as_many_engine_calls_as_its_longest_half_axis(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    calls = [0]
    run = margins.outcomes_at

    def counted(*args: object, **kwargs: object) -> object:
        calls[0] += 1
        return run(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(margins, "outcomes_at", counted)
    design = xf.x_face(0.25, 1.0)
    outcome = xf.predict(design, 0.3, 0.2, path=False).outcome
    alone = []
    for axis, direction in ((0, -1.0), (0, 1.0), (1, -1.0), (1, 1.0)):
        calls[0] = 0
        margins.flip_distance(
            design, 0.3, 0.2, outcome, axis=axis, direction=direction,
            limit=2.0 * design.mated_distance if axis == 0 else math.pi,
            step=margins.LATERAL_STEP if axis == 0 else margins.ANGLE_STEP,
            resolution=LATERAL_RESOLUTION if axis == 0 else ANGLE_RESOLUTION,
            physics=xf.Physics(),
        )  # fmt: skip
        alone.append(calls[0])
    calls[0] = 0
    margins.outcome_margins(design, 0.3, 0.2, outcome)
    assert calls[0] == max(alone) < sum(alone)
