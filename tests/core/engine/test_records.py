"""records.py: options from Physics, the run record's fields, the codes, fresh work arrays."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

import xface_core as xf
from xface_core import codes
from xface_core._engine import records
from xface_core._engine.simulate import simulate
from xface_core.physics import Physics, SolverSettings
from xface_core.runner import engine_model, start_heights


def test_infinite_damping_ratio_holds_the_base() -> None:
    opts = records.make_options(Physics(damping_ratio=math.inf))
    assert (opts.winv_b, opts.sqrt_winv_b) == (0.0, 0.0)
    assert (opts.winv_m, opts.sqrt_winv_m) == (1.0, 1.0)


def test_damping_ratio_sets_the_inverse_weights_and_their_roots() -> None:
    opts = records.make_options(Physics(damping_ratio=4.0))
    assert opts.winv_b == 0.25
    assert opts.sqrt_winv_b == 0.5
    assert opts.winv_m == 1.0
    assert opts.sqrt_winv_m == 1.0


def test_options_carry_the_settings_and_friction() -> None:
    settings = SolverSettings(rtol=1e-6, atol=1e-9, event_tol=1e-11, max_steps=77, max_events=9)
    opts = records.make_options(Physics(friction=0.3, settings=settings))
    assert (opts.rtol, opts.atol, opts.event_tol) == (1e-6, 1e-9, 1e-11)
    assert (opts.max_steps, opts.max_events) == (77, 9)
    assert (opts.touch_tol, opts.seat_tol) == (settings.touch_tol, settings.seat_tol)
    assert (opts.max_step, opts.first_step) == (settings.max_step, settings.first_step)
    assert opts.jam_speed == settings.jam_speed
    assert opts.friction == 0.3
    assert type(opts.max_steps) is int
    assert type(opts.max_events) is int


def test_run_dtype_fields() -> None:
    i, f, b = np.dtype(np.int64), np.dtype(np.float64), np.dtype(np.bool_)
    expected = {
        "outcome": i, "reason": i, "phi_b": f, "phi_m": f, "y_m": f, "steps": i, "events": i,
        "contact_changes": i, "rejected_steps": i, "n_samples": i, "x0": f, "y_floor": f,
        "h": f, "n_active": i, "n_excluded": i, "had_contact": b,
    }  # fmt: skip
    assert {name: records.RUN_DTYPE[name] for name in records.RUN_DTYPE.names} == expected


#: Engine constant prefix of each code enum, and the members spelled differently there.
_PREFIXES = {"O_": codes.Outcome, "R_": codes.Reason, "P_": codes.Phase, "E_": codes.EventKind}
_SPELLING = {"O_INVALID": "INVALID_INPUT"}


@pytest.mark.parametrize("prefix", sorted(_PREFIXES))
def test_engine_code_constants_are_exactly_the_enum_members(prefix: str) -> None:
    enum = _PREFIXES[prefix]
    constants = {
        name: value
        for name, value in vars(records).items()
        if name.startswith(prefix) and name.isupper() and isinstance(value, int)
    }
    as_members = {_SPELLING.get(n, n[len(prefix) :]): v for n, v in constants.items()}
    assert as_members == {m.name: m.value for m in enum}
    assert all(type(v) is int for v in constants.values())  # plain ints: numba folds them


def test_slip_state_constants_are_the_enum_values() -> None:
    named = {s.name: s.value for s in codes.SlipState}
    assert {n: getattr(records, n) for n in named} == named


def test_undecided_is_no_outcome() -> None:
    assert records.UNDECIDED not in {o.value for o in codes.Outcome}


def test_new_work_is_sized_for_the_model_and_cleared() -> None:
    model = engine_model(xf.v_face(0.5, 1.0))
    work = records.new_work(model, records.make_options(Physics()))
    n = model.pairs.shape[0]
    assert work.ev.shape == (n, 6)
    for name in ("g_prev", "u_prev", "g_next", "u_next", "thr"):
        assert getattr(work, name).shape == (n,)
    assert np.all(work.thr == 0.0)
    assert work.cand.shape == (model.pairs.shape[0],)
    assert np.array_equal(work.exclude, np.full(records.MAX_EXCLUDED, -1))
    assert np.array_equal(work.act, [-1, -1, -1, -1])
    assert np.array_equal(work.slip, [records.FREE, records.FREE])


def test_reset_work_returns_a_used_work_to_how_new_work_starts_it() -> None:
    model = engine_model(xf.s_face(0.5, 1.0))
    opts = records.make_options(Physics())
    fresh, used = records.new_work(model, opts), records.new_work(model, opts)
    runs = np.zeros(1, dtype=records.RUN_DTYPE)
    path, pairs = np.zeros((1, 4)), np.full((1, 4), -1, dtype=np.int64)
    y = float(start_heights(xf.s_face(0.5, 1.0), np.array([0.2]))[0])
    simulate(model, opts, 0.1, 0.2, y, runs[0], path, pairs, used)
    assert runs[0]["steps"] > 0  # the run did use it
    assert not np.array_equal(used.step_memo, fresh.step_memo)
    records.reset_work(used)
    # Every array new_work initialises (the others are written before they are read).
    for name in ("thr", "exclude", "act", "slip", "rays", "samples", "step_memo", "sleep",
                 "dense"):  # fmt: skip
        assert np.array_equal(getattr(used, name), getattr(fresh, name)), name
    # new_work sets them through reset_work: their values as a run starts, spelled out.
    for name in ("thr", "rays", "samples", "step_memo", "dense"):
        assert not np.any(getattr(fresh, name)), name
    n = model.pairs.shape[0]
    assert np.array_equal(fresh.sleep, np.column_stack([np.zeros(n), -np.ones(n), np.zeros(n)]))


#: The engine functions compiled with numba's reference counting (NRT): the entries from
#: Python and the helpers that make arrays (for the entries, and for the tests). Everything
#: a run calls below ``simulate.simulate`` allocates nothing and runs without it.
ENTRIES_WITH_NRT = {
    "records.new_work", "segment.begin_segment",
    # Inlined: the segment's tuple is built under its caller's (no) reference counting.
    "records.frictionless", "records.held_contacts", "segment._segment",
    "simulate._final_values", "simulate._options", "simulate._run_pose",
    "simulate._run_recorded", "simulate._start", "simulate.lowest_reach",
    "simulate.path_arrays", "simulate.simulate_final",
    "simulate.simulate_many", "simulate.simulate_one", "simulate.simulate_path",
    "simulate.start_heights_of",
}  # fmt: skip


def _engine_functions() -> dict[str, Any]:
    """Every compiled function of the engine by ``module.name``."""
    import importlib
    import pkgutil

    from numba.core.registry import CPUDispatcher

    import xface_core._engine as engine

    found = {}
    for info in pkgutil.iter_modules(engine.__path__):
        module = importlib.import_module(f"{engine.__name__}.{info.name}")
        for name, value in vars(module).items():
            if isinstance(value, CPUDispatcher) and value.__module__ == module.__name__:
                found[f"{info.name}.{name}"] = value
    return found


def test_the_engine_below_its_entries_runs_without_reference_counting() -> None:
    # Under NRT every array read out of a record counts a reference, two atomic operations:
    # the per-interval stages once spent about 8 % of an S-Face map on them.
    with_nrt = {
        name for name, f in _engine_functions().items() if f.targetoptions.get("_nrt", True)
    }
    assert with_nrt == ENTRIES_WITH_NRT


#: The innermost arithmetic numba inlines into its callers (records.njit_inline): callers
#: use part of a pair's nine values, and inlined, LLVM drops the rest (maps 0.89 of their
#: time, bit for bit, docs/notes/2026-11-24-inlined-pair-arithmetic.md), so none of these
#: may lose it unnoticed.
INLINED = {
    "events.contact_value", "pairs._cone_admits", "pairs._side_of_all", "pairs.adjacent_gap",
    "pairs.clipped_gap", "pairs.eval_pair", "pairs.pair_at", "pairs.wedges_cross",
    "pairs.vertex_in_edge_frame", "records.frictionless", "records.held_contacts",
    "records.touch_depth", "scan._crossing", "segment._segment",
} | {
    # The step memo's look-ups: a call passes a Segment (about fifty words) by value, which
    # cost more than a look-up that finds its answer (maps 0.86-0.95 of their time, bit
    # for bit, docs/notes/2026-11-29-side-by-side-memo-look-ups-inlined.md).
    "events._remembers", "events._remembered_velocity", "events.angles_at",
    "events.end_velocity", "events.has_dense", "events.quarter_state",
    "events.start_velocity", "events.step_to", "events._state_and_rate",
} | {
    # The stages of a step's scan and the trial step, each called once per step: a call
    # passes Segment and Work (about two hundred words) by value (maps about 0.92 of their
    # time, bit for bit, docs/notes/2026-11-30-scan-stages-inlined.md).
    "scan._active_events", "scan._slip_events", "scan._contact_events",
    "scan._contacts_before", "scan._crossed_at_event", "scan.find_event",
    "segment.trial_step", "segment._error_scales",
}  # fmt: skip


#: The small helpers of the entry points (records.njit_wrapper): inlined, they do not each
#: link and optimise the whole engine again (the build: 84 against 100 s of CPU).
WRAPPERS = {
    "simulate._final_values", "simulate._options", "simulate._run_pose",
    "simulate._run_recorded", "simulate._start",
}  # fmt: skip


def _inlined() -> set[str]:
    return {
        name
        for name, f in _engine_functions().items()
        if f.targetoptions.get("inline", "never") == "always"
    }


def test_the_innermost_arithmetic_is_inlined_into_its_callers() -> None:
    assert _inlined() - WRAPPERS == INLINED


def test_the_entry_points_helpers_are_inlined_into_them() -> None:
    assert _inlined() & WRAPPERS == WRAPPERS
