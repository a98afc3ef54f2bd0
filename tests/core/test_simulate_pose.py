"""runner.simulate_pose (behind predict) builds the same Prediction, field for field and bit
for bit, as the way it was built before the compiled single-pose entries: ``simulate_one``
with the options NamedTuple, the start height from ``start_height``, a re-run for a path
longer than the buffer, and the path converted with numpy in Python. That old way is kept
here, copied, as the reference."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest

import xface_core as xf
from xface_core import _engine
from xface_core._engine import simulate as _simulate
from xface_core.codes import Outcome, Reason
from xface_core.geometry import FaceDesign
from xface_core.physics import Physics, SolverSettings
from xface_core.result import AlignmentPath, Counters, Prediction
from xface_core.runner import (
    PATH_BUFFER,
    _frozen,
    check_pose,
    engine_model,
    engine_options,
    simulate_pose,
    start_height,
)

FloatArray = npt.NDArray[np.float64]


# ---- the reference: simulate_pose as it was (runner.py at cf5015c) -----------------------
def reference_pose(
    design: FaceDesign,
    x0: float,
    theta0: float,
    physics: Physics,
    *,
    y_start: float | None = None,
    path: bool = True,
) -> Prediction:
    check_pose(design, x0, theta0, y_start)
    w = design.width
    x0_d = x0 / w
    y0_d = start_height(design, theta0) if y_start is None else y_start / w
    model = engine_model(design)
    opts = _engine.make_options(physics)
    run = np.zeros(1, dtype=_engine.RUN_DTYPE)
    n_buf = PATH_BUFFER if path else 1
    while True:
        buf = np.empty((n_buf, 4))
        pairs = np.empty((n_buf, 4), dtype=np.int64)
        _engine.simulate_one(model, opts, x0_d, float(theta0), y0_d, run, buf, pairs)
        if not path or run["n_samples"][0] <= n_buf:
            break
        n_buf = int(run["n_samples"][0])
    r = run[0]
    return Prediction(
        design=design,
        x0=float(x0),
        theta0=float(theta0),
        y_start=y0_d * w,
        outcome=Outcome(int(r["outcome"])),
        reason=Reason(int(r["reason"])).text,
        phi_b=float(r["phi_b"]),
        phi_m=float(r["phi_m"]),
        pivot_m=(float(x0), float(r["y_m"]) * w),
        counters=Counters(
            steps=int(r["steps"]),
            events=int(r["events"]),
            contact_changes=int(r["contact_changes"]),
            rejected_steps=int(r["rejected_steps"]),
        ),
        path=_alignment_path(buf, pairs, min(int(r["n_samples"]), n_buf), x0, y0_d, w)
        if path
        else None,
    )


def _alignment_path(
    buf: FloatArray, pairs: npt.NDArray[np.int64], n: int, x0: float, y0_d: float, w: float
) -> AlignmentPath:
    return AlignmentPath(
        descent=(y0_d - buf[:n, 0]) * w,
        phi_b=buf[:n, 1].copy(),
        phi_m=buf[:n, 2].copy(),
        pivot_m=_pivot_track(buf[:n, 0], x0, w),
        phase=buf[:n, 3].astype(np.int64),
        contact_pairs=pairs[:n].copy(),
    )


def _pivot_track(y_m: FloatArray, x0: float, w: float) -> FloatArray:
    out = np.empty((len(y_m), 2))
    out[:, 0] = x0
    out[:, 1] = y_m * w
    return out


# ---- the comparison ----------------------------------------------------------------------
def assert_same_value(new: Any, old: Any, where: str) -> None:
    """Equal, of the same type, and for floats and arrays the same bits."""
    assert type(new) is type(old), where
    if isinstance(old, np.ndarray):
        assert new.dtype == old.dtype, where
        assert new.shape == old.shape, where
        assert np.array_equal(new, old), where
        assert new.tobytes() == old.tobytes(), where  # also tells -0.0 from 0.0
        assert new.flags.c_contiguous, where
        assert new.flags.writeable, where
    elif isinstance(old, float):
        assert math.copysign(1.0, new) == math.copysign(1.0, old), where
        assert new == old or (math.isnan(new) and math.isnan(old)), where
    elif isinstance(old, tuple):
        assert len(new) == len(old), where
        for k, (a, b) in enumerate(zip(new, old, strict=True)):
            assert_same_value(a, b, f"{where}[{k}]")
    elif dataclasses.is_dataclass(old):
        for f in dataclasses.fields(old):
            assert_same_value(getattr(new, f.name), getattr(old, f.name), f"{where}.{f.name}")
    else:
        assert new == old, where


def assert_same_prediction(new: Prediction, old: Prediction) -> None:
    assert type(new) is Prediction
    assert_same_value(new, old, "prediction")
    with pytest.raises(dataclasses.FrozenInstanceError):
        new.x0 = 1.0  # type: ignore[misc]
    for part in (new.counters, new.path):
        if part is not None:
            with pytest.raises(dataclasses.FrozenInstanceError):
                part.steps = 1  # type: ignore[union-attr]


#: Damping 1e-3 with friction 0.2: this X-Face pose seats along 1127 samples (found by a
#: search over random poses), longer than the path buffer, so the entry runs it again.
LONG = (xf.x_face(0.25, 2.0), 0.18512676205293044, 0.17661026966206306)
LONG_PHYSICS = Physics(damping_ratio=1e-3, friction=0.2)

CASES: list[tuple[str, FaceDesign, float, float, Physics, dict[str, Any]]] = [
    ("X 0.25/2", xf.x_face(0.25, 2.0), 0.3, 0.2, Physics(), {}),
    ("X 1/1", xf.x_face(1.0, 1.0), 0.3, 0.2, Physics(), {}),
    ("V 0.5/1", xf.v_face(0.5, 1.0), 0.3, 0.2, Physics(), {}),
    ("S 0.5/1", xf.s_face(0.5, 1.0), 0.3, 0.2, Physics(), {}),
    ("S no path", xf.s_face(0.5, 1.0), 0.3, 0.2, Physics(), {"path": False}),
    ("V no path", xf.v_face(0.5, 1.0), -0.4, 0.3, Physics(), {"path": False}),
    ("S y_start", xf.s_face(0.5, 1.0), -0.2, -0.1, Physics(), {"y_start": 3.0}),
    ("X y_start int", xf.x_face(0.5, 1.0), 0, 0, Physics(), {"y_start": 4}),
    ("V friction", xf.v_face(0.5, 1.0), 0.3, 0.2, Physics(friction=0.3), {}),
    ("S friction", xf.s_face(2.0, 0.5), 0.4, -0.3, Physics(friction=0.6), {}),
    ("X base fixed", xf.x_face(0.25, 2.0), -0.3, 0.25, Physics(damping_ratio=math.inf), {}),
    (
        "V base fixed no path",
        xf.v_face(2.0, 0.2),
        0.4,
        -0.4,
        Physics(damping_ratio=math.inf),
        {"path": False},
    ),
    ("X width 0.05", xf.x_face(0.25, 2.0, width=0.05), 0.015, 0.2, Physics(), {}),
    ("S width 3 y_start", xf.s_face(0.5, 1.0, width=3.0), 0.6, 0.1, Physics(), {"y_start": 8.0}),
    ("out of reach", xf.x_face(0.0625, 0.0), 0.5, 0.0, Physics(), {}),
    ("overlapping start", xf.v_face(0.5, 1.0), 0.0, 0.0, Physics(), {"y_start": 1.0}),
    ("long path", *LONG, LONG_PHYSICS, {}),
    ("long path no path", *LONG, LONG_PHYSICS, {"path": False}),
]


@pytest.mark.parametrize(
    ("design", "x0", "theta0", "physics", "kwargs"),
    [case[1:] for case in CASES],
    ids=[case[0] for case in CASES],
)
def test_simulate_pose_builds_the_prediction_the_old_way_built(
    design: FaceDesign, x0: float, theta0: float, physics: Physics, kwargs: dict[str, Any]
) -> None:
    new = simulate_pose(design, x0, theta0, physics, **kwargs)
    old = reference_pose(design, x0, theta0, physics, **kwargs)
    assert_same_prediction(new, old)


@pytest.mark.parametrize("cls", [Prediction, Counters, AlignmentPath])
def test_the_result_types_can_be_built_without_their_init(cls: type) -> None:
    # runner._frozen sets the fields of these frozen dataclasses straight into __dict__ (as
    # unpickling does), which skips a __post_init__ and does not work with slots.
    assert dataclasses.is_dataclass(cls)
    assert cls.__dataclass_params__.frozen  # type: ignore[attr-defined]
    assert not hasattr(cls, "__post_init__")
    assert "__slots__" not in vars(cls)
    values = {f.name: k for k, f in enumerate(dataclasses.fields(cls))}
    built = _frozen(cls, **values)
    assert type(built) is cls
    assert vars(built) == vars(cls(**values))


def test_the_long_case_outruns_the_path_buffer() -> None:
    p = simulate_pose(*LONG, LONG_PHYSICS)
    assert p.path is not None
    assert len(p.path) > PATH_BUFFER


def test_the_cases_cover_every_kind_of_end() -> None:
    outcomes = {reference_pose(d, x0, t0, ph, **kw).outcome for _, d, x0, t0, ph, kw in CASES}
    assert {Outcome.SEATED, Outcome.BAD_MATE, Outcome.OUT_OF_REACH} <= outcomes
    assert Outcome.INVALID_INPUT in outcomes


def test_predict_is_simulate_pose() -> None:
    design = xf.v_face(0.5, 1.0)
    new = xf.predict(design, 0.3, 0.2, friction=0.1)
    assert_same_prediction(new, reference_pose(design, 0.3, 0.2, Physics(friction=0.1)))


def _options_through_the_engine(physics: Physics) -> _engine.Options:
    """The Options NamedTuple the single-pose entries rebuild from ``engine_options``."""
    opts: _engine.Options = _simulate._options(engine_options(physics))
    return opts


@pytest.mark.parametrize(
    "physics",
    [
        Physics(),
        Physics(friction=0.2),
        Physics(damping_ratio=math.inf),
        Physics(damping_ratio=3e-4, settings=SolverSettings(max_steps=123, max_events=45)),
    ],
)
def test_engine_options_give_the_engine_the_same_options(physics: Physics) -> None:
    rebuilt = _options_through_the_engine(physics)
    expected = _engine.make_options(physics)
    assert type(rebuilt) is _engine.Options
    assert_same_value(tuple(rebuilt), tuple(expected), "options")  # values and int/float


def test_engine_options_are_cached_by_identity_and_right_for_equal_physics() -> None:
    physics = Physics(friction=0.3)
    assert engine_options(physics) is engine_options(physics)
    assert not engine_options(physics).flags.writeable
    twin = Physics(physics.damping_ratio, physics.friction, physics.settings)
    assert np.array_equal(engine_options(twin), engine_options(physics))


def test_engine_options_stay_right_past_the_cache_size() -> None:
    values = [Physics(friction=0.01 * k) for k in range(100)]
    for physics in values:
        assert engine_options(physics)[-1] == physics.friction
    for physics in values[::7]:
        expected = _engine.option_values(_engine.make_options(physics))
        assert np.array_equal(engine_options(physics), expected)
