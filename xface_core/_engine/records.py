"""The engine's records: an immutable model and options, a mutable run state, work arrays.

Shaped like MuJoCo's ``mjModel`` / ``mjData``: everything that does not change during a run
(:class:`Model`: the design's pair table and edges; :class:`Options`: tolerances, budgets and
physics) is an immutable NamedTuple built once in Python; everything a run changes lives in
one row of :data:`RUN_DTYPE` (the run's state and counters, which is also what
``simulate_many`` returns per pose) and in :class:`Work` (scratch arrays of the contact
search). Integer codes are read from :mod:`xface_core.codes` and folded into compile-time
constants here, so the engine and the typed results cannot drift apart.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import Any, NamedTuple, TypeVar, cast

import numpy as np
import numpy.typing as npt
from numba import njit

from xface_core.codes import EventKind, Outcome, Phase, Reason, SlipState
from xface_core.physics import Physics

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
#: cos and sin of phi_B, then of phi_M, at one state.
Trig = tuple[float, float, float, float]

_F = TypeVar("_F", bound=Callable[..., Any])
#: numba's flags for every kernel without reference counting (:func:`njit_no_refcount`).
_NO_REFCOUNT_FLAGS: dict[str, Any] = {"cache": True, "nogil": True, "_nrt": False}
#: numba's flags for the kernels that allocate or hand arrays to Python (:func:`njit_cached`).
_CACHED_FLAGS: dict[str, Any] = {"cache": True, "nogil": True}


def one_specialization_per_type(dispatcher: _F) -> _F:
    """Make the compiled ``dispatcher`` compile one version per argument *type* when another
    kernel calls it, not one per literal value.

    numba types a constant argument (a code such as ``O_SEATED``, a flag, a count) as a
    literal of its value and compiles the callee, and everything it calls, once per value:
    ``end_run`` had 14 versions and the engine 186 compiled functions where 131 kernels
    suffice. Compiling for the plain type instead gives the same machine arithmetic (numba
    does not compile with fast-math, so LLVM may not reassociate; the golden maps are equal
    bit for bit) and cut a fresh install's first ``xface predict`` from 128 to 96 s of CPU
    (docs/notes/2026-11-28-engine-compile-time.md).
    """
    from numba.core import types

    plain_call_template = getattr(dispatcher, "get_call_template", None)
    if plain_call_template is None:  # NUMBA_DISABLE_JIT=1: njit gave the plain function back
        return dispatcher

    def get_call_template(args: tuple[Any, ...], kws: dict[str, Any]) -> Any:
        return plain_call_template(
            tuple(types.unliteral(a) for a in args),
            {key: types.unliteral(value) for key, value in kws.items()},
        )

    cast(Any, dispatcher).get_call_template = get_call_template
    return dispatcher


def njit_no_refcount(fn: _F) -> _F:
    """Compile a kernel without numba's reference counting (NRT), cached, GIL released, one
    version per argument type (:func:`one_specialization_per_type`).

    With NRT every call counts a reference, an atomic add and subtract, for every array it
    is passed and every array it reads out of a record; over the engine's many small stage
    calls that bookkeeping made the split engine 1.3x slower than the monolithic kernel, and
    without it the engine runs in about half the old kernel's time (``scripts/
    bench_side_by_side.py``). The price: such a kernel, and every kernel it calls, must not
    allocate (no np.empty, no slice copies) and must not return arrays (the caller would
    release a reference it never got). Kernels that allocate use :func:`njit_cached`;
    numba compiles their callees with NRT as their own flags say.
    """
    return one_specialization_per_type(cast(_F, njit(**_NO_REFCOUNT_FLAGS)(fn)))


def njit_cached(fn: _F) -> _F:
    """Compile a kernel that allocates or returns arrays (with numba's reference counting),
    cached, GIL released, one version per argument type: the entry points and their
    helpers."""
    return one_specialization_per_type(cast(_F, njit(**_CACHED_FLAGS)(fn)))


def njit_wrapper(fn: _F) -> _F:
    """A small helper of the entry points (it may allocate), inlined by numba into each of
    them instead of compiled on its own: every kernel is a library of its own in which LLVM
    links and optimises everything it calls again, so each wrapper level between an entry
    point and ``simulate`` cost one more pass over the whole engine. Inlined, the build of
    the entry points took 84 instead of 100 s of CPU, with no change at run time
    (docs/notes/2026-11-28-engine-compile-time.md)."""
    return one_specialization_per_type(cast(_F, njit(nogil=True, inline="always")(fn)))


def njit_inline(fn: _F) -> _F:
    """:func:`njit_no_refcount` for the innermost arithmetic that many stages call and use
    part of (a pair's gap and edge parameter out of its nine values): numba inlines it into
    each caller before LLVM sees it (``inline="always"``), so what a caller does not use is
    never computed and no tuple is passed back through memory. Bit for bit the same
    arithmetic; the maps 0.94 of their time for ``pairs.eval_pair`` alone
    (docs/notes/2026-11-24-inlined-pair-arithmetic.md).
    Also the stages of a step's scan and the trial step (``scan.find_event`` and what it
    calls once, ``segment.trial_step``): each runs once per step, and a call copies every
    field of the ``Segment`` and ``Work`` it is passed (about two hundred words); inlined,
    the maps took about 0.92 of their time, bit for bit, and the engine's build 104 s of
    CPU instead of 72 (docs/notes/2026-11-30-scan-stages-inlined.md).
    A caller must pass its arguments one by one (numba cannot inline a call with ``*args``).
    """
    return one_specialization_per_type(cast(_F, njit(**_NO_REFCOUNT_FLAGS, inline="always")(fn)))


# ---- codes as plain ints (numba folds module globals into constants) ---------------------
UNDECIDED = -1  # the run's outcome while it is still going
O_INVALID = int(Outcome.INVALID_INPUT)
O_OUT_OF_REACH = int(Outcome.OUT_OF_REACH)
O_NO_CONTACT = int(Outcome.NO_CONTACT)
O_SEATED = int(Outcome.SEATED)
O_BAD_MATE = int(Outcome.BAD_MATE)
O_PASSED = int(Outcome.PASSED)
O_UNRESOLVED = int(Outcome.UNRESOLVED)

R_SEATED = int(Reason.SEATED)
R_JAMMED = int(Reason.JAMMED)
R_BELOW_SEAT = int(Reason.BELOW_SEAT)
R_PASSED = int(Reason.PASSED)
R_NO_CONTACT = int(Reason.NO_CONTACT)
R_SPUN = int(Reason.SPUN)
R_SINGULAR = int(Reason.SINGULAR)
R_STEP_LIMIT = int(Reason.STEP_LIMIT)
R_EVENT_LIMIT = int(Reason.EVENT_LIMIT)
R_OVERLAP = int(Reason.OVERLAP)
R_OUT_OF_REACH = int(Reason.OUT_OF_REACH)
R_NONFINITE = int(Reason.NONFINITE)
R_FRICTION_LOCK = int(Reason.FRICTION_LOCK)

P_APPROACH = int(Phase.APPROACH)
P_ALIGN = int(Phase.ALIGN)
P_SLIDE = int(Phase.SLIDE)
P_END = int(Phase.END)

E_NONE = int(EventKind.NONE)
E_CONTACT = int(EventKind.CONTACT)
E_RELEASE = int(EventKind.RELEASE)
E_OFF_EDGE = int(EventKind.OFF_EDGE)
E_BELOW_SEAT = int(EventKind.BELOW_SEAT)
E_SPUN = int(EventKind.SPUN)
E_TURN = int(EventKind.TURN)
E_SLIP = int(EventKind.SLIP)

#: Friction state of an active contact (``Work.slip[k]``).
FREE = int(SlipState.FREE)
STICK = int(SlipState.STICK)
SLIDE_POSITIVE = int(SlipState.SLIDE_POSITIVE)
SLIDE_NEGATIVE = int(SlipState.SLIDE_NEGATIVE)

# ---- geometric and numerical constants of the engine -------------------------------------
TINY = 1e-300
ALIGN_TOL = 1e-9  # rad: |phi_B - phi_M| below which a sample is labelled SLIDE
U_TOL = 1e-9  # edge-parameter slack of "inside the edge's span"
U_CORNER = 1e-6  # edge-parameter slack within which a vertex meets an edge's end corner
#: D: a vertex this close to an edge's end corner meets the corner (vertex on vertex): its
#: pair is one alternative of the motion choice, never a constraint held on its own.
CORNER_REACH = 1e-7
#: D: a contact function this close to zero is zero to round-off (coordinates of a few D
#: carry about 1e-15); at both ends of a search it cannot bracket a crossing.
FLAT_GAP = 1e-14
#: rad per (rad/D): how closely a state solved on contacts that pin the path is known, per
#: unit of its rate. The gaps carry about FLAT_GAP of round-off, and the angles that zero
#: them that over the constraints' smallest singular value, which near a fold of the path
#: falls as the rate grows (segment.error_at_roundoff: no step is asked to be more accurate).
PINNED_ROUNDOFF = FLAT_GAP
CUT_DEPTH = 1e-7  # D: deeper than this, a jump to a fold cut into a contact
#: rad per accepted step: near a fold of the contact path the rate grows without bound and a
#: long step could jump across thin features. 0.05 and 0.1 change no outcome but make final
#: angles less accurate (p99 error 4e-10 -> 1.9e-9 rad on the bench's maps) and the maps were
#: no faster beyond this machine's noise: not kept (docs/notes/
#: 2026-11-23-corner-touching-rule-and-reference-check.md).
MAX_TURN = 0.02
#: D: a segment's descent step is kept within half the design's shortest edge (a vertex
#: that goes in past a corner and out again then ends within half an edge of that corner,
#: where the test of two corners crossed like an X looks: scan._crossing), but never below
#: this, the longest step before the cap was by design (settings.max_step, 0.05 D): faces
#: with finer features step as they did (segment.step_cap).
STEP_CAP_FLOOR = 0.05
#: D of descent ahead at which a friction state is judged: at a transition the state at the
#: point itself is marginal (motion.friction_modes, events.locate).
SLIP_PROBE = 1e-7
#: Two frictional contacts are held while each force is above -PUSH_SLACK times the larger:
#: on a flush edge friction can leave one end's force at about -1e-4 of the other's, and
#: released it is closed again at once (interval._both_push, the release event).
PUSH_SLACK = 1e-3
#: A stuck contact holds while its friction force is within 1 + STICK_SLACK of the cone
#: mu lambda, and a sliding one is chosen only while it slips faster than SLIP_FLOOR times the
#: size of its slip rate's terms: on the boundary of the cone the slip rate is zero to
#: round-off, and sliding was chosen again every 3e-4 D (damping ratio 1e-4, mu 0.1: the
#: event budget) where the contact, its force on the cone, sticks.
STICK_SLACK = 1e-6
SLIP_FLOOR = 1e-9
#: Touching tolerances a pair may lie behind its edge's line and still count as touching.
#: Every event that stops a touching pair's crossing leaves it up to one touching tolerance
#: deeper; with a window of 4 a pair that went through four such events dropped out of the
#: touching set and out of the contact search ("already behind its line") and the parts
#: then cut into each other unnoticed.
TOUCH_WINDOW = 64.0


@njit_inline
def touch_depth(touch_tol: float) -> float:
    """How far (D) behind its edge's line a pair may lie and still count as touching:
    ``TOUCH_WINDOW`` touching tolerances (``touch_tol``, D)."""
    return TOUCH_WINDOW * touch_tol


MAX_EXCLUDED = 8  # pairs kept out of the touching set at one point of the path
#: Every trial step samples the contact functions of pairs near their edge at k / 4 of the
#: step (a vertex in and out again past a corner within the step) ...
COARSE_SAMPLES = 3
#: ... and at k / 32 when its end shows two corners crossed like an X (the vertex that went
#: in and out again did so in a sliver of the step; seen: 8 % of it).
FINE_SAMPLES = 31
FOLD_RISE = 1e-6  # D: a located turn's fold must lie this close to the turn's height
FOLD_REACH = 1e-3  # D: solve_fold accepts a fold only this close to its start height
#: Integration steps from one trial step's start remembered per segment (events.step_to):
#: the event scan asks for the same state again and again (the trial step's end in every
#: root search, a located event's state in the contact checks and in the advance to it).
STEP_MEMO_SLOTS = 16
#: Columns of the step memo: a remembered step takes 9 (``events.step_to``), row 0 the memo's
#: bookkeeping and the remembered states (``events.START_RATE``, ``END_RATE``,
#: ``QUARTER_STATE``).
STEP_MEMO_WIDTH = 48
#: D: a pair is left out of the contact scans only while its vertex stays this much farther
#: from its edge than it can move (above every touching and corner tolerance).
SLEEP_SLACK = 1e-6
#: Width of a dense-output row (integrate.rk_step writes one, integrate.dense_angles reads
#: it): the step's start (phi_B, phi_M, y_M), its length, whether set, the four
#: coefficients of the interpolant beyond the start for phi_B, then for phi_M, and the step's
#: error estimate of phi_B and phi_M (rad; the interpolant's error is of its order).
DENSE_WIDTH = 15


class Model(NamedTuple):
    """What the engine knows of a design (units of D); immutable."""

    pairs: FloatArray
    """(n_pairs, 10) vertex-edge pair table (columns: :mod:`xface_core.contact`)."""
    base_edges: FloatArray
    """(n, 5) base edges: x0, y0, x1, y1, layer (body frame)."""
    moving_edges: FloatArray
    """(n, 5) moving edges: x0, y0, x1, y1, layer (body frame)."""
    mated_distance: float
    """Pivot-to-pivot distance L when seated (D)."""


class Options(NamedTuple):
    """Tolerances, budgets and physics of a run; immutable (see :class:`SolverSettings`)."""

    rtol: float
    atol: float
    event_tol: float
    touch_tol: float
    seat_tol: float
    max_step: float
    first_step: float
    max_steps: int
    max_events: int
    jam_speed: float
    winv_b: float
    """Inverse rotational damping of the base relative to the moving part (0: base fixed)."""
    winv_m: float
    sqrt_winv_b: float
    sqrt_winv_m: float
    friction: float
    """Coulomb coefficient at every contact."""


@functools.lru_cache(maxsize=64)
def make_options(physics: Physics) -> Options:
    """The engine's options for a validated :class:`~xface_core.physics.Physics` (cached:
    both are immutable, and every prediction asks)."""
    s = physics.settings
    winv_b = 0.0 if math.isinf(physics.damping_ratio) else 1.0 / physics.damping_ratio
    winv_m = 1.0
    return Options(
        rtol=float(s.rtol),
        atol=float(s.atol),
        event_tol=float(s.event_tol),
        touch_tol=float(s.touch_tol),
        seat_tol=float(s.seat_tol),
        max_step=float(s.max_step),
        first_step=float(s.first_step),
        max_steps=int(s.max_steps),
        max_events=int(s.max_events),
        jam_speed=float(s.jam_speed),
        winv_b=winv_b,
        winv_m=winv_m,
        sqrt_winv_b=math.sqrt(winv_b),
        sqrt_winv_m=math.sqrt(winv_m),
        friction=float(physics.friction),
    )


#: One run's state and counters; a (n,) array of it is ``simulate_many``'s output.
RUN_DTYPE = np.dtype(
    [
        ("outcome", np.int64),  # Outcome, or UNDECIDED while running
        ("reason", np.int64),  # Reason
        ("phi_b", np.float64),  # base angle (rad)
        ("phi_m", np.float64),  # moving angle (rad)
        ("y_m", np.float64),  # moving pivot height (D)
        ("steps", np.int64),  # accepted integration steps
        ("events", np.int64),  # located events
        ("contact_changes", np.int64),  # changes of the active-set size
        ("rejected_steps", np.int64),  # steps rejected by the error control
        ("n_samples", np.int64),  # path samples recorded (may exceed the buffer)
        ("x0", np.float64),  # lateral offset of the moving pivot (D), fixed
        ("y_floor", np.float64),  # seat height less the seat tolerance (D)
        ("h", np.float64),  # next trial step (D of descent)
        ("n_active", np.int64),  # active contacts (Work.act[:n_active])
        ("n_excluded", np.int64),  # pairs kept out of the touching set (Work.exclude)
        ("had_contact", np.bool_),  # touched at least once
    ]
)


class Work(NamedTuple):
    """Scratch arrays of one run (the contact search's per-pair values and the active set).

    Every array a run needs is here, made once per batch (:func:`new_work`), so that the
    engine below the batch entries allocates nothing and runs without reference counting
    (:func:`njit_no_refcount`)."""

    ev: FloatArray
    """(n_pairs, 6) per pair: gap, edge parameter, dg/dphi_B, dg/dphi_M, dg/dy_M, du/dd."""
    g_prev: FloatArray
    """Gap of every pair at the start of the trial step."""
    u_prev: FloatArray
    """Edge parameter of every pair at the start of the trial step."""
    g_next: FloatArray
    """Gap of every pair at the end of the trial step."""
    u_next: FloatArray
    thr: FloatArray
    """Per pair: the gap at which it counts as a new contact in this interval."""
    cand: IntArray
    """Touching pairs (first n)."""
    exclude: IntArray
    """Pairs released or slid off at the current point, kept out until the path progresses
    (so a corner touching several features cannot cycle)."""
    act: IntArray
    """Active contacts (first ``n_active``; 4 slots, -1 padded)."""
    slip: IntArray
    """Friction state (:class:`~xface_core.codes.SlipState`) of active contacts 0 and 1."""
    rays: FloatArray
    """(4, 2) scratch of the corner test (:func:`~.pairs.corner_motion_admissible`)."""
    samples: FloatArray
    """(FINE_SAMPLES, 6) scratch: phi_B, phi_M and their cos and sin (cos phi_B, sin phi_B,
    cos phi_M, sin phi_M) at the samples inside a trial step."""
    step_memo: FloatArray
    """(STEP_MEMO_SLOTS + 1, STEP_MEMO_WIDTH) steps integrated in this segment
    (:func:`~.events.step_to`), and states whose rates were asked for."""
    sleep: FloatArray
    """(n_pairs, 3) per pair, within a segment: how far (D) its vertex and edge must still
    move relative to each other before it can come into reach (a contact, or two corners
    crossing), this trial step's bound on that motion while it is out of reach (-1: in
    reach, looked at), and 1 while its values at the step's start (``g_prev``, ``u_prev``)
    are stale (:func:`~.scan.wake`)."""
    dense: FloatArray
    """(2, DENSE_WIDTH) dense output of the last step integrated (row 0) and of the trial
    step being scanned for events (row 1, :func:`~.events.keep_trial_dense`)."""
    choice: IntArray
    """(3, n_pairs + 2) scratch of the motion choice (:func:`~.motion.choose_motion`): the
    hard contacts, the corner contacts and the corner alternatives."""
    trial: IntArray
    """(4,) scratch of the motion choice: the active set of the alternative being tried."""
    world_b: FloatArray
    """(base edges, 4) scratch: the base's edges in the world (:func:`~.overlap.overlapping`)."""
    world_m: FloatArray
    """(moving edges, 4) scratch: the moving part's edges in the world."""
    near: IntArray
    """Pairs whose vertex comes within the trial step's travel of their edge (first n, from
    :func:`~.scan._contact_events`): the only ones :func:`~.scan._contacts_inside_step`
    samples."""
    sleep_holds: IntArray
    """(1,) 1 from an event inside a scanned step until the next segment has started: the
    budgets in ``sleep`` still hold at the run's state, so the interval's start and the
    segment's evaluate only the pairs in reach (:func:`~.interval.begin_interval`,
    :func:`~.segment.start_segment`)."""
    corner_memo: FloatArray
    """(n_pairs, 4) per pair: whether its vertex and the start corner of its edge crossed
    like an X (1.0, else 0.0: :func:`~.pairs.wedges_cross`) at the state (phi_B, phi_M,
    y_M) in the other three columns, NaN for none yet. The state at the end of a scanned
    step is the next step's start, bit for bit (:func:`~.scan._crossing`)."""


class Contacts(NamedTuple):
    """The active contacts and the metric the parts move in (units of D, rad): all that the
    rate (:func:`~.motion.velocity`), the projection and the pinned solves need. A kernel
    call passes every field of its arguments, and numba inlines none of these: the rate,
    asked for seven times a step and more in every event search, takes this, not the whole
    :class:`Segment` (whose step memo and dense output it does not read)."""

    pairs: FloatArray
    act: IntArray
    """Active contacts (first ``n_active``)."""
    n_active: int
    mu: float
    """Coulomb coefficient at every contact."""
    slip: IntArray
    """Friction states of the active contacts (see :class:`Work`)."""
    x0: float
    """The moving part's pivot's x (D)."""
    sqrt_winv_b: float
    sqrt_winv_m: float
    winv_b: float
    winv_m: float
    """The least-dissipation metric W^-1 (and its square roots) of the base and the moving
    part (see :class:`Options`)."""


class Segment(NamedTuple):
    """What is fixed along one smooth segment of the path: the step context every stage of
    the segment takes whole (Box2D's ``b2StepContext``)."""

    held: Contacts
    y_floor: float
    """Seat height less the seat tolerance (D): below it a seat is out of reach."""
    step_memo: FloatArray
    """Steps already integrated in this segment (:func:`~.events.step_to`; emptied by
    :func:`~.events.clear_step_memo` whenever a segment begins)."""
    dense: FloatArray
    """Dense output of the last step integrated and of the trial step
    (:func:`~.events.keep_trial_dense`, :func:`~.events.angles_at`)."""


class Step(NamedTuple):
    """A trial step: its start state and its length in descent."""

    phi_b: float
    phi_m: float
    y_m: float
    h: float


@njit(inline="always")
def held_contacts(
    model: Model, opts: Options, work: Work, n_active: int, mu: float, x0: float
) -> Contacts:
    """The first ``n_active`` contacts of ``work.act`` held with Coulomb coefficient ``mu``,
    the moving pivot at ``x0`` (D). Inlined, so the tuple of arrays is built under the
    caller's reference counting (none in the engine)."""
    return Contacts(
        model.pairs, work.act, n_active, mu, work.slip, x0, opts.sqrt_winv_b, opts.sqrt_winv_m,
        opts.winv_b, opts.winv_m,
    )  # fmt: skip


@njit(inline="always")
def frictionless(held: Contacts) -> Contacts:
    """``held`` without friction (``mu`` 0), for the rate that friction turns."""
    return Contacts(
        held.pairs, held.act, held.n_active, 0.0, held.slip, held.x0, held.sqrt_winv_b,
        held.sqrt_winv_m, held.winv_b, held.winv_m,
    )  # fmt: skip


@njit_cached
def new_work(model: Model, opts: Options) -> Work:
    """Fresh scratch arrays for one run (or a batch of runs, :func:`reset_work` between
    them), set as a run starts by :func:`reset_work` itself."""
    n = model.pairs.shape[0]
    work = Work(
        np.empty((n, 6)),
        np.empty(n),
        np.empty(n),
        np.empty(n),
        np.empty(n),
        np.empty(n),
        # Room for every pair: a flush contact of finely divided outlines touches many pairs
        # at once, and a pair left out of the motion choice would be cut into unseen.
        np.empty(n, dtype=np.int64),
        np.empty(MAX_EXCLUDED, dtype=np.int64),
        np.empty(4, dtype=np.int64),
        np.empty(2, dtype=np.int64),
        np.empty((4, 2)),
        np.empty((FINE_SAMPLES, 6)),
        np.empty((STEP_MEMO_SLOTS + 1, STEP_MEMO_WIDTH)),
        np.empty((n, 3)),
        np.empty((2, DENSE_WIDTH)),
        np.empty((3, n + 2), dtype=np.int64),
        np.empty(4, dtype=np.int64),  # choose_motion sets it before each use
        np.empty((model.base_edges.shape[0], 4)),
        np.empty((model.moving_edges.shape[0], 4)),
        np.empty(n, dtype=np.int64),  # written by each scan before it is read
        np.zeros(1, dtype=np.int64),
        np.empty((n, 4)),
    )
    reset_work(work)
    return work


@njit_no_refcount
def reset_work(work: Work) -> None:
    """Set the scratch arrays as a run starts: :func:`new_work` does it once, and a batch puts
    a used one back between runs with it (one allocation per batch instead of 15 per run).
    The arrays left out are written before they are read."""
    work.thr[:] = 0.0
    work.exclude[:] = -1
    work.act[:] = -1
    work.slip[:] = FREE
    work.rays[:] = 0.0
    work.samples[:] = 0.0
    work.step_memo[:] = 0.0
    work.sleep[:] = 0.0
    work.sleep[:, 1] = -1.0  # every pair in reach
    work.sleep_holds[0] = 0
    work.dense[:] = 0.0
    work.corner_memo[:] = math.nan
