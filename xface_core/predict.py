"""Predict a dock: the typed entry points around the compiled kernel.

Lengths are in the design's unit (``design.width`` is the face width D), angles in radians.
The kernel works in units of D, so maps and outcomes do not depend on the unit.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from . import kernel as K
from .contact import pair_table
from .errors import InputError, XfaceValueError
from .geometry import FaceDesign
from .outcome import Outcome
from .result import AlignmentPath, Counters, Prediction

__all__ = ["REASONS", "BatchResult", "SolverSettings", "predict", "predict_batch", "start_height"]

FloatArray = npt.NDArray[np.float64]

#: Largest accepted Coulomb friction coefficient (steel on steel is about 0.6).
MAX_FRICTION = 10.0

#: Smallest batch share worth a thread of its own.
MIN_POSES_PER_THREAD = 64

#: Path samples allocated up front; longer paths trigger one re-run with an exact buffer.
PATH_BUFFER = 256

#: Largest accepted |x0| and |y_start|, in widths D: beyond this the geometry is absurd
#: and double precision cannot resolve the contact.
MAX_OFFSET = 1.0e6

REASONS: dict[int, str] = {
    K.R_SEATED: "seated: equal angles, profiles flush",
    K.R_JAMMED: "jammed misaligned: no further descent is possible",
    K.R_BELOW_SEAT: "descended below the seat height: a seat can no longer be reached",
    K.R_PASSED: "slid past the base: no further contact along the approach",
    K.R_NO_CONTACT: "the faces never touch along the approach",
    K.R_SPUN: "a part rotated past +-pi",
    K.R_SINGULAR: "jammed: the contact normal runs through both pivots",
    K.R_STEP_LIMIT: "step limit reached before an outcome was decided",
    K.R_EVENT_LIMIT: "event limit reached before an outcome was decided",
    K.R_OVERLAP: "the start pose interpenetrates the parts",
    K.R_OUT_OF_REACH: "|x0| exceeds the mated pivot distance L: no seated pose exists",
    K.R_NONFINITE: "non-finite input",
    K.R_FRICTION_LOCK: "jammed by friction: no slip state lets the parts descend",
}


@dataclass(frozen=True)
class SolverSettings:
    """Numerical settings of the alignment integrator (lengths in D, angles in rad).

    The defaults give maps identical to those at tolerances 1e-12 (see ``xface bench``).
    """

    rtol: float = 1e-8
    """Relative error per step of the angles."""
    atol: float = 1e-10
    """Absolute error per step of the angles (rad)."""
    event_tol: float = 1e-12
    """Width (in descent, D) to which events are located."""
    touch_tol: float = 1e-9
    """Gap (D) below which a vertex-edge pair counts as touching."""
    seat_tol: float = 1e-4
    """Tolerance of the seated-pose test: |phi_B - phi_M| (rad) and the pivot's distance from
    the mated position (in D, per D of L). Where the path reaches the seat through a fold of
    the contact path (a pinned corner turning into flush flanks, as in the V-Face) the
    angles there are only determined to about sqrt(event_tol) times a geometric factor
    (1e-5 seen), so the test must be looser than that; 1e-4 D is far below any machining
    tolerance."""
    max_step: float = 0.05
    """Largest descent step (D); also bounds how far a vertex can move unchecked."""
    first_step: float = 1e-3
    """Initial descent step (D)."""
    max_steps: int = 20000
    max_events: int = 400
    jam_speed: float = 1e6
    """Rotation rate (rad per D of descent) treated as a jam (normal through both pivots)."""

    def vector(self, damping_ratio: float, friction: float = 0.0) -> FloatArray:
        """The kernel's settings vector for a damping ratio c_B / c_M and a Coulomb
        friction coefficient."""
        v = np.zeros(K.N_SETTINGS)
        v[K.S_RTOL] = self.rtol
        v[K.S_ATOL] = self.atol
        v[K.S_EVENT_TOL] = self.event_tol
        v[K.S_TOUCH_TOL] = self.touch_tol
        v[K.S_SEAT_TOL] = self.seat_tol
        v[K.S_MAX_STEP] = self.max_step
        v[K.S_FIRST_STEP] = self.first_step
        v[K.S_MAX_STEPS] = self.max_steps
        v[K.S_MAX_EVENTS] = self.max_events
        v[K.S_WINV_B] = 0.0 if math.isinf(damping_ratio) else 1.0 / damping_ratio
        v[K.S_WINV_M] = 1.0
        v[K.S_JAM_SPEED] = self.jam_speed
        v[K.S_FRICTION] = friction
        return v

    def tightened(self, factor: float) -> SolverSettings:
        """All tolerances multiplied by ``factor`` (< 1 tightens)."""
        return replace(
            self,
            rtol=self.rtol * factor,
            atol=self.atol * factor,
            event_tol=max(self.event_tol * factor, 1e-15),
        )


DEFAULT_SETTINGS = SolverSettings()


def _check_physics(damping_ratio: float, friction: float) -> None:
    if not (damping_ratio > 0.0):  # also rejects NaN
        raise XfaceValueError(
            f"damping_ratio must be > 0 (inf locks the base), got {damping_ratio}"
        )
    if not (0.0 <= friction <= MAX_FRICTION):  # also rejects NaN
        raise XfaceValueError(f"friction must be in [0, {MAX_FRICTION:g}], got {friction}")


def start_heights(design: FaceDesign, theta0: npt.ArrayLike) -> FloatArray:
    """Lowest moving-pivot heights (units of D) at which the parts are clear of each other
    for any x0, plus a small clearance: the default start of the approach, per angle
    (vectorised; non-finite angles give NaN)."""
    th = np.asarray(theta0, dtype=np.float64)
    finite = np.isfinite(th)
    th = np.where(finite, th, 0.0)
    table = pair_table(design)
    v = table.moving_vertices
    # A moving body point v sits at y_M - (sin th v_x + cos th v_y).
    reach = (np.sin(th)[..., None] * v[:, 0] + np.cos(th)[..., None] * v[:, 1]).max(axis=-1)
    return np.asarray(np.where(finite, table.base_top + reach + 0.01, np.nan), dtype=np.float64)


def start_height(design: FaceDesign, theta0: float) -> float:
    """:func:`start_heights` for one angle (compiled: no numpy overhead per call)."""
    table = pair_table(design)
    return table.base_top + K.lowest_reach(table.moving_vertices, float(theta0)) + 0.01


def predict(
    design: FaceDesign,
    x0: float,
    theta0: float,
    *,
    y_start: float | None = None,
    damping_ratio: float = 1.0,
    friction: float = 0.0,
    path: bool = True,
    margins: bool = False,
    settings: SolverSettings = DEFAULT_SETTINGS,
) -> Prediction:
    """Predict whether the faces seat from one initial relative pose.

    Parameters
    ----------
    design : FaceDesign
        The connector (``design.width`` is D in the caller's length unit).
    x0 : float
        Lateral offset of the moving pivot (length).
    theta0 : float
        Initial angle of the moving part relative to the mated orientation (rad).
    y_start : float, optional
        Initial height of the moving pivot above the base pivot (length). Default: just
        clear of the base for this angle (the approach is exact, so the start does not
        change the outcome as long as the parts do not overlap).
    damping_ratio : float
        Rotational damping of the base over that of the moving part, c_B / c_M; ``inf``
        holds the base fixed.
    friction : float
        Coulomb friction coefficient at every contact (0, the paper's assumption, by
        default; the paper names friction as future work).
    path : bool
        Keep the alignment path (costs memory, not much time).
    margins : bool
        Also search the distance to the nearest pose with a different outcome.

    Returns
    -------
    Prediction

    Examples
    --------
    >>> from xface_core import x_face
    >>> p = predict(x_face(0.25, 2.0), 0.3, 0.2)
    >>> p.outcome.name, p.seated
    ('SEATED', True)
    >>> predict(x_face(0.25, 0.0), 0.9, 0.0).outcome.name
    'OUT_OF_REACH'
    """
    _check_physics(damping_ratio, friction)
    w = design.width
    for name, value in (("x0", x0), ("theta0", theta0), ("y_start", y_start)):
        if value is not None and not math.isfinite(value):
            raise InputError(f"{name} must be finite, got {value!r}")
    if abs(x0) > MAX_OFFSET * w or (y_start is not None and abs(y_start) > MAX_OFFSET * w):
        raise InputError(f"|x0| and |y_start| must be <= {MAX_OFFSET:g} widths")
    if abs(theta0) > 2.0 * math.pi:
        raise InputError(f"|theta0| must be <= 2 pi, got {theta0!r}")
    x0_d = x0 / w
    y0_d = start_height(design, theta0) if y_start is None else y_start / w
    table = pair_table(design)
    vector = settings.vector(damping_ratio, friction)
    n_buf = PATH_BUFFER if path else 1
    while True:
        buf = np.empty((n_buf, 4))
        pairs = np.empty((n_buf, 4), dtype=np.int64)
        out = K.simulate(
            table.data,
            table.base_edges,
            table.moving_edges,
            design.mated_distance,
            x0_d,
            float(theta0),
            y0_d,
            vector,
            buf,
            pairs,
        )
        # A path longer than the buffer: run again with room for all of it (the kernel is
        # deterministic, so the second run is the same run).
        if not path or out[-1] <= n_buf:
            break
        n_buf = int(out[-1])
    code, reason, pb, pm, ym, steps, events, changes, rejected, n = out
    alignment = None
    if path:
        n = min(n, n_buf)
        alignment = AlignmentPath(
            descent=(y0_d - buf[:n, 0]) * w,
            phi_b=buf[:n, 1].copy(),
            phi_m=buf[:n, 2].copy(),
            pivot_m=np.column_stack((np.full(n, x0), buf[:n, 0] * w)),
            phase=buf[:n, 3].astype(np.int64),
            contact_pairs=pairs[:n].copy(),
        )
    prediction = Prediction(
        design=design,
        x0=float(x0),
        theta0=float(theta0),
        y_start=y0_d * w,
        outcome=Outcome(code),
        reason=REASONS[reason],
        phi_b=float(pb),
        phi_m=float(pm),
        pivot_m=(float(x0), float(ym) * w),
        counters=Counters(
            steps=int(steps),
            events=int(events),
            contact_changes=int(changes),
            rejected_steps=int(rejected),
        ),
        path=alignment,
    )
    if margins:
        from .margins import outcome_margins

        prediction = replace(
            prediction,
            margins=outcome_margins(
                design,
                x0,
                theta0,
                prediction.outcome,
                damping_ratio=damping_ratio,
                friction=friction,
                settings=settings,
            ),
        )
    return prediction


@dataclass(frozen=True)
class BatchResult:
    """Outcomes and final states of many poses of one design (arrays of the input's shape)."""

    outcome: npt.NDArray[np.int8]
    """Outcome codes (values of :class:`Outcome`)."""
    phi_b: FloatArray
    phi_m: FloatArray
    steps: npt.NDArray[np.int64]
    events: npt.NDArray[np.int64]


def predict_batch(
    design: FaceDesign,
    x0: npt.ArrayLike,
    theta0: npt.ArrayLike,
    *,
    damping_ratio: float = 1.0,
    friction: float = 0.0,
    settings: SolverSettings = DEFAULT_SETTINGS,
    threads: int | None = None,
) -> BatchResult:
    """Predict many poses of one design (broadcast like numpy; no paths).

    ``threads`` splits a large batch over threads (default: one per core); the compiled
    kernel releases the GIL, so they run in parallel, and every pose's result is the same
    bit for bit whatever the split.

    Non-finite or absurd entries give ``INVALID_INPUT`` in their cell instead of raising,
    like shapely's vectorised functions return NaN for missing input.

    Examples
    --------
    >>> from xface_core import v_face
    >>> r = predict_batch(v_face(0.5, 1.0), [0.0, 0.2, float("nan")], 0.1)
    >>> [Outcome(c).name for c in r.outcome]
    ['SEATED', 'SEATED', 'INVALID_INPUT']
    """
    _check_physics(damping_ratio, friction)
    xb, tb = np.broadcast_arrays(
        np.asarray(x0, dtype=np.float64), np.asarray(theta0, dtype=np.float64)
    )
    xs = (xb / design.width).ravel()
    ts = tb.ravel()
    table = pair_table(design)
    code, pb, pm, steps, events = _run_flat(
        table.data,
        table.base_edges,
        table.moving_edges,
        design,
        xs,
        ts,
        settings.vector(damping_ratio, friction),
        threads,
    )
    shape = xb.shape
    return BatchResult(
        outcome=code.reshape(shape),
        phi_b=pb.reshape(shape),
        phi_m=pm.reshape(shape),
        steps=steps.reshape(shape),
        events=events.reshape(shape),
    )


def _run_flat(
    table: FloatArray,
    base_edges: FloatArray,
    moving_edges: FloatArray,
    design: FaceDesign,
    xs: FloatArray,
    ts: FloatArray,
    vector: FloatArray,
    threads: int | None = None,
) -> tuple[
    npt.NDArray[np.int8], FloatArray, FloatArray, npt.NDArray[np.int64], npt.NDArray[np.int64]
]:
    """Run the kernel over flat arrays of x0 (units of D) and theta0."""
    ys = np.nan_to_num(start_heights(design, ts))
    valid = (
        np.isfinite(xs) & np.isfinite(ts) & (np.abs(xs) <= MAX_OFFSET) & (np.abs(ts) <= 2 * np.pi)
    )
    n_threads = (os.cpu_count() or 1) if threads is None else max(1, threads)
    n_threads = min(n_threads, max(1, len(xs) // MIN_POSES_PER_THREAD))

    def run(
        part: slice,
    ) -> tuple[
        npt.NDArray[np.int8],
        FloatArray,
        FloatArray,
        npt.NDArray[np.int64],
        npt.NDArray[np.int64],
    ]:
        return K.simulate_many(
            table,
            base_edges,
            moving_edges,
            design.mated_distance,
            xs[part],
            ts[part],
            ys[part],
            valid[part],
            vector,
        )

    if n_threads == 1:
        return run(slice(None))
    # Interleaved chunks balance the load: hard poses cluster in parts of a map.
    parts = [slice(k, None, n_threads) for k in range(n_threads)]
    with ThreadPoolExecutor(n_threads) as pool:
        results = list(pool.map(run, parts))
    out = tuple(np.empty(len(xs), dtype=r.dtype) for r in results[0])
    for part, res in zip(parts, results, strict=True):
        for dest, src in zip(out, res, strict=True):
            dest[part] = src
    return out  # type: ignore[return-value]
