"""Rerun recordings of predictions and acceptance maps, for review in the rerun viewer.

This is the only module of :mod:`xface_core` that imports rerun (``rerun-sdk`` 0.41, from the
``viz`` extra: ``pip install '.[viz]'`` in the xface checkout); nothing imports it eagerly,
so the simulator runs without it. Everything goes through an explicit
:class:`rerun.RecordingStream` made by :func:`new_recording`: no global or thread-local
rerun state is read or changed.

Conventions
-----------
Units
    Lengths in the design's unit (``design.width`` is the face width D; metres in the ROS
    node), angles in radians.
Upright pictures
    Rerun's 2-D views draw y downwards and (in 0.41) ignore view coordinates. The geometry is
    logged in true world coordinates (y up, as in the simulator) under a parent entity that
    carries a static mirror transform ``Transform3D(mat3x3=diag(1, -1, 1))``; the 2-D views of
    the blueprint take the parent of that entity as their origin, so the mirror applies and
    the base is drawn below the moving part. Values read back from the file are the
    simulator's own coordinates.
Timelines
    ``step`` (sequence): the path sample index, 0 at the start of each prediction.
    ``sim_descent`` (duration): the simulation's own clock: how far the arm has driven the
    moving pivot down since the start, at a notional approach speed of one length unit per
    second (quasi-static motion has no other time; 1 s on this timeline is one length unit).
    ``ros2_timestamp`` (timestamp): the ROS header stamp of the pose the prediction was
    made for, rerun's ROS convention; only when ``ros_stamp_ns`` is given, the same stamp on
    every sample of the prediction (scrubbing it shows each prediction's final state). The
    node's verdicts (:func:`log_verdict`) live on this timeline only: one row per prediction,
    so "accepted over time" is a plot and a session's BAD_MATEs a query.
Determinism
    :func:`new_recording` turns off rerun's automatic ``log_time`` and ``log_tick`` columns
    and does not send the recording properties (whose start time is the wall clock); the
    path data goes in with ``send_columns``, which never injects them. With a fixed
    ``recording_id`` two recordings of the same prediction compare equal with
    ``rerun rrd compare`` (they are not byte-identical: rerun's row ids carry the wall clock).

Entity tree (``entity="xface"``, ``entity="map"`` by default)::

    xface/design                mirror transform (static)
    xface/design/base/layer{k}  base outline of layer k, body frame (static)
    xface/design/moving/layer{k} moving outline, mated at x0 = 0 (static)
    xface/design/pivots         both pivots in the mated pose (static)
    xface/scene                 mirror transform (static)
    xface/scene/base/layer{k}   base outline per path sample
    xface/scene/moving/layer{k} moving outline per path sample
    xface/scene/target/layer{k} the seated pose of the moving part for this x0 (at step 0)
    xface/scene/pivots          base and moving pivot per sample
    xface/scene/contacts        active contact points per sample
    xface/scene/normals         contact normals (into the moving part) per sample
    xface/phase                 StateChange: the phase per sample
    xface/log                   TextLog: the start, every phase change, the outcome
    xface/series/{phi_b,phi_m,descent,gap}  Scalars per sample
    xface/scene/pivot_path      LineStrips2D: the moving pivot's whole path (at step 0)
    xface/design/values         AnyValues: face, H/D, r_p, width, L, layers (static)
    xface/verdict/{outcome_code,accepted,seat_probability}  Scalars, one row per prediction
    xface/verdict/input/{x0,theta0,y_start}   the query pose, one row per prediction
    xface/verdict/margin/{lateral_minus,lateral_plus,angle_minus,angle_plus}  the margins
    map                         AnnotationContext: outcome legend (static)
    map/cells                   mirror transform (static)
    map/cells/image             SegmentationImage of Outcome values (static)
    map/cells/guaranteed        Boxes2D: the guaranteed-acceptance rectangle (static)
    map/cells/axes              Points2D: axis end labels (static)
    map/grid                    Tensor of outcomes (x0 x theta0) and the axes (static)
    map/summary                 TextDocument: design, M, counts per outcome (static)
"""

from __future__ import annotations

import math
import uuid
import weakref
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import rerun as rr
import rerun.blueprint as rrb
import shapely

from xface_core.codes import Outcome
from xface_core.errors import XfaceValueError, is_integer_in
from xface_core.geometry import FaceDesign
from xface_core.result import Phase, Prediction

from . import palette
from .mapimage import AcceptanceMapLike, checked_grid, guaranteed_cells, outcome_colors

__all__ = [
    "default_blueprint",
    "log_acceptance_map",
    "log_design",
    "log_prediction",
    "log_verdict",
    "new_recording",
]

FloatArray = npt.NDArray[np.float64]

#: Maps the world (y up) onto rerun's 2-D view space (y down): a mirror about the x axis.
_Y_UP = rr.Transform3D(mat3x3=[[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]])

_BASE_COLORS = palette.BASE_LAYERS
_MOVING_COLORS = palette.MOVING_LAYERS
_TARGET_COLOR = (150, 150, 150)
_CONTACT_COLOR = palette.REDDISH_PURPLE
_PIVOT_COLOR = palette.YELLOW
_PHASE_COLORS = {
    Phase.APPROACH: palette.SKY_BLUE,
    Phase.ALIGN: palette.ORANGE,
    Phase.SLIDE: palette.BLUISH_GREEN,
    Phase.END: (150, 150, 150),
}
_LINE = rr.Radius.ui_points(1.5)
_THIN = rr.Radius.ui_points(1.0)
#: Drawn length of a contact normal, in widths D.
_NORMAL_LENGTH_D = 0.2
_LEVELS = {
    Outcome.SEATED: "INFO",
    Outcome.INVALID_INPUT: "ERROR",
    Outcome.UNRESOLVED: "ERROR",
}


def _root(entity: str) -> str:
    """A root entity path without its slashes; an empty one would put the tree at the
    recording's root, where it collides with everything else."""
    root = str(entity).strip("/")
    if not root:
        raise XfaceValueError(f"entity must name a path such as 'xface', got {entity!r}")
    return root


# --- the stream and its layout ----------------------------------------------------------------


def default_blueprint(
    *,
    entity: str = "xface",
    map_entity: str = "map",
    active: str = "prediction",
) -> rrb.Blueprint:
    """The viewer layout built in code: "prediction", "node timeline" and "acceptance map"
    tabs.

    The prediction tab shows the 2-D scene (with the design in a second tab beside it), the
    angles, the descent and the gap over the path, the phase, and the text log. The node
    timeline tab shows the verdict series of :func:`log_verdict` (outcome code, accepted,
    margins, the input pose) over the ROS stamps, with the scene beside them. The map tab
    shows the map image with its legend and the summary.

    Parameters
    ----------
    entity, map_entity : str
        The entities given to :func:`log_prediction` and :func:`log_acceptance_map`.
    active : {"prediction", "node", "map"}
        The tab shown first ("node" also sets the time panel to ``ros2_timestamp``).

    Examples
    --------
    >>> bp = default_blueprint(active="map")
    >>> type(bp).__name__
    'Blueprint'
    """
    tabs = ("prediction", "node", "map")
    if active not in tabs:
        raise XfaceValueError(f"active must be one of {', '.join(tabs)}; got {active!r}")
    e, m = _root(entity), _root(map_entity)
    scene = rrb.Spatial2DView(name="scene", origin=e, contents=f"/{e}/scene/**")
    design = rrb.Spatial2DView(name="design", origin=e, contents=f"/{e}/design/**")
    angles = rrb.TimeSeriesView(
        name="angles (rad)",
        origin=f"{e}/series",
        contents=[f"/{e}/series/phi_b", f"/{e}/series/phi_m"],
    )
    lengths = rrb.TimeSeriesView(
        name="descent and gap (length)",
        origin=f"{e}/series",
        contents=[f"/{e}/series/descent", f"/{e}/series/gap"],
    )
    phase = rrb.StateTimelineView(name="phase", origin=f"{e}/phase")
    log = rrb.TextLogView(name="log", origin=f"{e}/log")
    prediction_tab = rrb.Horizontal(
        rrb.Tabs(scene, design),
        rrb.Vertical(angles, lengths, phase, log, row_shares=[3, 3, 2, 3]),
        column_shares=[3, 2],
        name="prediction",
    )
    verdicts = rrb.TimeSeriesView(
        name="outcome code and accepted",
        origin=f"{e}/verdict",
        contents=[f"/{e}/verdict/outcome_code", f"/{e}/verdict/accepted"],
    )
    margins = rrb.TimeSeriesView(name="margins", origin=f"{e}/verdict/margin")
    inputs = rrb.TimeSeriesView(name="input pose", origin=f"{e}/verdict/input")
    node_tab = rrb.Horizontal(
        rrb.Spatial2DView(name="scene", origin=e, contents=f"/{e}/scene/**"),
        rrb.Vertical(verdicts, margins, inputs, log),
        column_shares=[2, 3],
        name="node timeline",
    )
    map_tab = rrb.Horizontal(
        rrb.Spatial2DView(name="acceptance map", origin=m, contents=f"/{m}/cells/**"),
        rrb.TextDocumentView(name="summary", origin=f"{m}/summary"),
        column_shares=[3, 1],
        name="acceptance map",
    )
    if active == "map":
        time_panel = rrb.TimePanel(state="collapsed")
    else:
        # Paused: the viewer opens on a still picture. A prediction's series run over the
        # simulation's own clock (the descent, the quasi-static path parameter); a node's
        # verdicts over the stamps of the poses they answer.
        timeline = "sim_descent" if active == "prediction" else "ros2_timestamp"
        time_panel = rrb.TimePanel(state="expanded", timeline=timeline, play_state="paused")
    return rrb.Blueprint(
        rrb.Tabs(prediction_tab, node_tab, map_tab, active_tab=tabs.index(active)),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        time_panel,
    )


def new_recording(
    *,
    application_id: str = "xface",
    recording_id: str | uuid.UUID | None = None,
    path: str | Path | None = None,
    url: str | None = None,
    blueprint: bool | rrb.Blueprint = True,
) -> rr.RecordingStream:
    """A new explicit rerun recording stream, writing to a file and/or a live viewer.

    Parameters
    ----------
    application_id : str
        Rerun's application id (the viewer groups recordings by it).
    recording_id : str or UUID, optional
        Fix it for reproducible files (tests, golden files); default: a fresh random id.
    path : str or Path, optional
        Write an ``.rrd`` file there. Call ``rec.disconnect()`` when done: it flushes and
        writes the file's footer (``rerun rrd verify`` rejects a file without it).
    url : str, optional
        Also stream to a live viewer over gRPC, e.g. ``rerun+http://127.0.0.1:9876/proxy``.
        Connecting returns at once; data is buffered until the viewer answers.
    blueprint : bool or rerun.blueprint.Blueprint
        True: send :func:`default_blueprint` (prediction tab first) as the default layout;
        a Blueprint: send that one; False: none (the viewer's own heuristics). The viewer
        keeps one layout per application id: give maps their own id (``"xface-map"``) so a
        viewer that shows a prediction opens a map on the map tab.

    Raises
    ------
    XfaceValueError
        The file cannot be created (no such folder, no permission).

    Returns
    -------
    rerun.RecordingStream
        With ``log_time`` and ``log_tick`` off and no recording properties sent (so output
        is deterministic given ``recording_id``); with neither ``path`` nor ``url`` it
        buffers in memory until a sink is attached.

    Examples
    --------
    >>> rec = new_recording(recording_id="doc-example")
    >>> rec.get_recording_id()
    'doc-example'
    """
    if path is not None:
        # Before the stream exists: a stream whose file sink failed keeps what it buffered
        # in memory, and rerun warns about dropping it at exit, after our one-line error.
        try:
            with open(path, "ab"):  # creates the file, keeps an existing one for rerun
                pass
        except OSError as exc:
            raise XfaceValueError(
                f"cannot write the recording {str(path)!r}: {exc.strerror}"
            ) from exc
    rec = rr.RecordingStream(
        application_id,
        recording_id=recording_id if recording_id is not None else uuid.uuid4(),
        send_properties=False,  # the properties carry the wall-clock start time
    )
    rec.set_log_time_enabled(False)
    rec.set_log_tick_enabled(False)
    layout: rrb.Blueprint | None
    if blueprint is True:
        layout = default_blueprint()
    elif blueprint is False:
        layout = None
    elif isinstance(blueprint, rrb.Blueprint):
        layout = blueprint
    else:
        raise XfaceValueError(f"blueprint must be a bool or a rerun Blueprint, got {blueprint!r}")
    sinks: list[rr.FileSink | rr.GrpcSink] = []
    if path is not None:
        sinks.append(rr.FileSink(Path(path)))
    if url is not None:
        sinks.append(rr.GrpcSink(url))
    if sinks:
        # A default, not an active blueprint: a user's own layout in a running viewer stays.
        try:
            rec.set_sinks(*sinks, default_blueprint=layout)
        except RuntimeError as exc:  # rerun's own error for a file it cannot create
            where = f"the recording {str(path)!r}" if path is not None else f"the viewer {url!r}"
            raise XfaceValueError(f"cannot write {where}: {exc}") from exc
    elif layout is not None:
        rec.send_blueprint(layout, make_active=False, make_default=True)
    return rec


# --- geometry helpers ---------------------------------------------------------------------------


def _closed(poly: FloatArray) -> FloatArray:
    """Polygons (..., v, 2) as closed line strips (first vertex repeated at the end)."""
    return np.concatenate((poly, poly[..., :1, :]), axis=-2)


def _check_finite(name: str, values: npt.ArrayLike) -> None:
    if not np.all(np.isfinite(np.asarray(values, dtype=np.float64))):
        raise XfaceValueError(f"{name} holds NaN or infinity: nothing sensible to draw")


def log_design(rec: rr.RecordingStream, design: FaceDesign, *, entity: str = "xface") -> None:
    """Log the design statically: both parts' outlines per layer in the mated pose, pivots,
    and its parameters as values (``{entity}/design/values``: face, h_over_d, r_p, width,
    mated_distance in the design's unit, n_layers; NaN H/D and r_p for a custom face).

    The base is at its body frame (pivot at the origin), the moving part seated at x0 = 0
    (pivot at (0, L)), in the design's length unit, under ``{entity}/design``.

    Parameters
    ----------
    rec : rerun.RecordingStream
    design : FaceDesign
    entity : str
        Root entity path.

    Examples
    --------
    >>> from xface_core import x_face
    >>> log_design(new_recording(recording_id="doc"), x_face(0.25, 1.0))
    """
    e = _root(entity)
    w = design.width
    L = design.mated_distance
    rec.log(f"{e}/design", _Y_UP, static=True)
    rec.log(
        f"{e}/design/values",
        rr.AnyValues(
            face=design.kind,
            h_over_d=design.h_over_d,
            r_p=design.r_p,
            width=w,
            mated_distance=L * w,
            n_layers=design.n_layers,
        ),
        static=True,
    )
    for k in range(design.n_layers):
        for part, outline, colors in (
            ("base", design.base_outline_world(k, 0.0), _BASE_COLORS),
            ("moving", design.moving_outline_world(k, 0.0, L, 0.0), _MOVING_COLORS),
        ):
            rec.log(
                f"{e}/design/{part}/layer{k}",
                rr.LineStrips2D(
                    [_closed(outline * w)],
                    colors=[colors[k % 2]],
                    radii=_LINE,
                    labels=[f"{part} layer {k}"],
                ),
                static=True,
            )
    rec.log(
        f"{e}/design/pivots",
        rr.Points2D(
            [[0.0, 0.0], [0.0, L * w]],
            labels=["base pivot", "moving pivot"],
            colors=[_PIVOT_COLOR],
            radii=rr.Radius.ui_points(4.0),
        ),
        static=True,
    )


def _path_arrays(
    prediction: Prediction,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, npt.NDArray[np.int64], bool]:
    """(descent, phi_b, phi_m, y_m, phase, has_path): the path, or only the final state."""
    path = prediction.path
    if path is not None and len(path) > 0:
        return (
            np.asarray(path.descent, dtype=np.float64),
            np.asarray(path.phi_b, dtype=np.float64),
            np.asarray(path.phi_m, dtype=np.float64),
            np.asarray(path.pivot_m, dtype=np.float64)[:, 1],
            np.asarray(path.phase, dtype=np.int64),
            True,
        )
    # A prediction made with path=False: one sample, the final state.
    y_m = prediction.pivot_m[1]
    return (
        np.array([prediction.y_start - y_m]),
        np.array([prediction.phi_b]),
        np.array([prediction.phi_m]),
        np.array([y_m]),
        np.array([int(Phase.END)]),
        False,
    )


def _gap(design: FaceDesign, base: list[FloatArray], moving: list[FloatArray]) -> FloatArray:
    """Smallest distance between equal layers of the two parts per sample (units of D).

    ``base[k]`` and ``moving[k]`` are (n, v, 2) outlines of layer k; zero in contact.
    """
    gaps = [
        shapely.distance(shapely.polygons(b), shapely.polygons(m))
        for b, m in zip(base, moving, strict=True)
    ]
    return np.asarray(np.min(np.vstack(gaps), axis=0), dtype=np.float64)


def _indexes(n: int, descent: FloatArray, ros_stamp_ns: int | None) -> list[rr.TimeColumn]:
    idx = [
        rr.TimeColumn("step", sequence=np.arange(n, dtype=np.int64)),
        # 1 s on this timeline = one length unit of descent (see the module docstring).
        rr.TimeColumn("sim_descent", duration=np.round(descent * 1e9).astype("timedelta64[ns]")),
    ]
    if ros_stamp_ns is not None:
        idx.append(
            rr.TimeColumn(
                "ros2_timestamp",
                timestamp=np.full(n, ros_stamp_ns, dtype=np.int64).astype("datetime64[ns]"),
            )
        )
    return idx


def _style(
    rec: rr.RecordingStream, entity: str, archetype: Any, color: tuple[int, int, int], radius: Any
) -> None:
    """Static colour and radius of an entity whose data changes along the path (static
    components apply at every time, so the per-sample rows carry only the geometry)."""
    rec.log(entity, archetype.from_fields(colors=[color], radii=radius), static=True)


#: What each stream already holds statically, per root entity: the design's key and whether
#: the design itself was logged. A node logs thousands of predictions of one design into one
#: stream; the static styles and the design need to go in once (and again when it changes).
_STATICS_LOGGED: weakref.WeakKeyDictionary[rr.RecordingStream, dict[str, object]] = (
    weakref.WeakKeyDictionary()
)


def _log_statics(rec: rr.RecordingStream, e: str, d: FaceDesign, *, with_design: bool) -> None:
    """Static parts of a prediction's entity tree: transform, styles, the design."""
    key = (d.cache_key, d.width, with_design)
    logged = _STATICS_LOGGED.setdefault(rec, {})
    if logged.get(e) == key:
        return
    if with_design:
        log_design(rec, d, entity=e)
    rec.log(f"{e}/scene", _Y_UP, static=True)
    for k in range(d.n_layers):
        _style(rec, f"{e}/scene/base/layer{k}", rr.LineStrips2D, _BASE_COLORS[k % 2], _LINE)
        _style(rec, f"{e}/scene/moving/layer{k}", rr.LineStrips2D, _MOVING_COLORS[k % 2], _LINE)
        _style(rec, f"{e}/scene/target/layer{k}", rr.LineStrips2D, _TARGET_COLOR, _THIN)
    _style(rec, f"{e}/scene/pivots", rr.Points2D, _PIVOT_COLOR, rr.Radius.ui_points(4.0))
    _style(rec, f"{e}/scene/pivot_path", rr.LineStrips2D, _PIVOT_COLOR, _THIN)
    _style(rec, f"{e}/scene/contacts", rr.Points2D, _CONTACT_COLOR, rr.Radius.ui_points(4.0))
    _style(rec, f"{e}/scene/normals", rr.Arrows2D, _CONTACT_COLOR, _THIN)
    rec.log(
        f"{e}/phase",
        rr.StateConfiguration(
            values=[p.name for p in Phase], colors=[_PHASE_COLORS[p] for p in Phase]
        ),
        static=True,
    )
    for name, color in (
        ("phi_b", _BASE_COLORS[0]),
        ("phi_m", _MOVING_COLORS[0]),
        ("descent", (200, 200, 200)),  # light: the viewer is dark
        ("gap", _CONTACT_COLOR),
    ):
        rec.log(f"{e}/series/{name}", rr.SeriesLines(names=[name], colors=[color]), static=True)
    logged[e] = key


def log_prediction(
    rec: rr.RecordingStream,
    prediction: Prediction,
    *,
    entity: str = "xface",
    ros_stamp_ns: int | None = None,
    design: bool = True,
) -> None:
    """Log one prediction along its alignment path (see the module docstring for the tree).

    Per path sample: the base and moving outlines of every layer, both pivots, the active
    contact points and their normals, the phase; the time series ``phi_b`` and ``phi_m``
    (rad), ``descent`` and ``gap`` (length; the gap is the smallest distance between equal
    layers of the two parts, zero in contact); text log lines for the start, each phase
    change and the outcome with its reason. A prediction made with ``path=False`` is logged
    as one sample, its final state.

    Timelines: ``step`` and ``sim_descent``, plus ``ros2_timestamp`` when ``ros_stamp_ns``
    (nanoseconds since the epoch, the pose's header stamp) is given. The data goes in with
    ``send_columns``, so the caller's own ``rec.set_time`` state is neither used nor changed.

    Parameters
    ----------
    rec : rerun.RecordingStream
    prediction : Prediction
    entity : str
        Root entity path (one per prediction stream; a node can reuse it per session).
    ros_stamp_ns : int, optional
        ROS header stamp of the pose, nanoseconds since the epoch.
    design : bool
        Also (re)log the static design (:func:`log_design`); cheap, idempotent.

    Raises
    ------
    XfaceValueError
        The prediction holds NaN or infinity in its pose or path, or the stamp is not an
        integer.

    Examples
    --------
    >>> from xface_core import predict, x_face
    >>> rec = new_recording(recording_id="doc")
    >>> log_prediction(
    ...     rec, predict(x_face(0.25, 2.0), 0.3, 0.2), ros_stamp_ns=1_700_000_000_000_000_000
    ... )
    """
    _check_stamp(ros_stamp_ns)
    e = _root(entity)
    d = prediction.design
    descent, phi_b, phi_m, y_m, phase, has_path = _path_arrays(prediction)
    _check_finite("the prediction's pose", [prediction.x0, prediction.theta0])
    _check_finite("the prediction's path", np.concatenate((descent, phi_b, phi_m, y_m)))
    n = descent.size
    idx = _indexes(n, descent, ros_stamp_ns)

    _log_statics(rec, e, d, with_design=design)
    first = _indexes(1, descent[:1], ros_stamp_ns)
    base_d, moving_d = _log_outlines(rec, e, prediction, (phi_b, phi_m, y_m), idx, first)
    _log_pivots(rec, e, prediction.x0, y_m, idx, first)
    _log_contacts(rec, e, prediction, n, has_path, idx)
    gap = _gap(d, base_d, moving_d) * d.width
    series = {"phi_b": phi_b, "phi_m": phi_m, "descent": descent, "gap": gap}
    _log_series(rec, e, phase, series, idx)
    _log_text(rec, e, prediction, phase, descent, ros_stamp_ns)


def log_verdict(
    rec: rr.RecordingStream,
    prediction: Prediction,
    *,
    accepted: bool,
    ros_stamp_ns: int,
    seat_probability: float | None = None,
    entity: str = "xface",
) -> None:
    """Log what a node answered for one pose as scalar series on ``ros2_timestamp``.

    One row per prediction at the pose's stamp, under ``{entity}/verdict``: ``outcome_code``
    (the :class:`~xface_core.Outcome` value), ``accepted`` (1 or 0: the node's decision,
    which may also ask for a margin), ``seat_probability`` when given, the query pose
    ``input/{x0,theta0,y_start}`` (design unit, rad) and, when the prediction has them, the
    margins ``margin/{lateral_minus,lateral_plus,angle_minus,angle_plus}`` (design unit,
    rad; an infinite margin, no flip within the searched range, is left out of that row).

    Examples
    --------
    >>> from xface_core import predict, x_face
    >>> rec = new_recording(recording_id="doc")
    >>> p = predict(x_face(0.25, 2.0), 0.3, 0.2, margins=True)
    >>> log_verdict(rec, p, accepted=p.seated, ros_stamp_ns=1_700_000_000_000_000_000)
    """
    _check_stamp(ros_stamp_ns)
    if ros_stamp_ns is None:
        raise XfaceValueError("log_verdict needs the pose's ros_stamp_ns")
    e = _root(entity)
    at = np.array([ros_stamp_ns], dtype=np.int64).astype("datetime64[ns]")
    stamp = rr.TimeColumn("ros2_timestamp", timestamp=at)
    values: dict[str, float] = {
        "outcome_code": float(int(prediction.outcome)),
        "accepted": 1.0 if accepted else 0.0,
        "input/x0": prediction.x0,
        "input/theta0": prediction.theta0,
        "input/y_start": prediction.y_start,
    }
    if seat_probability is not None:
        values["seat_probability"] = float(seat_probability)
    m = prediction.margins
    if m is not None:
        for name in ("lateral_minus", "lateral_plus", "angle_minus", "angle_plus"):
            value = float(getattr(m, name))
            if math.isfinite(value):
                values[f"margin/{name}"] = value
    for name, value in values.items():
        rec.send_columns(
            f"{e}/verdict/{name}", indexes=[stamp], columns=rr.Scalars.columns(scalars=[value])
        )


def _check_stamp(ros_stamp_ns: object) -> None:
    if ros_stamp_ns is not None and not is_integer_in(ros_stamp_ns, -(2**63), 2**63 - 1):
        raise XfaceValueError(f"ros_stamp_ns must be an integer (ns), got {ros_stamp_ns!r}")


def _log_outlines(
    rec: rr.RecordingStream,
    e: str,
    prediction: Prediction,
    path: tuple[FloatArray, FloatArray, FloatArray],
    idx: list[rr.TimeColumn],
    first: list[rr.TimeColumn],
) -> tuple[list[FloatArray], list[FloatArray]]:
    """Per layer: the base and moving outlines per sample of ``path = (phi_b, phi_m, y_m)``,
    and the seated target at the ``first`` sample. Returns the path outlines in units of D
    ((n, v + 1, 2) closed polygons per layer; base, then moving) for the gap."""
    phi_b, phi_m, y_m = path
    d = prediction.design
    w = d.width
    base_d = [_closed(d.base_outline_path(k, phi_b)) for k in range(d.n_layers)]
    moving_d = [
        _closed(d.moving_outline_path(k, prediction.x0 / w, y_m / w, phi_m))
        for k in range(d.n_layers)
    ]
    for k in range(d.n_layers):
        for part, outlines in (("base", base_d[k]), ("moving", moving_d[k])):
            rec.send_columns(
                f"{e}/scene/{part}/layer{k}",
                indexes=idx,
                columns=rr.LineStrips2D.columns(strips=(outlines * w).astype(np.float32)),
            )
        # The seated pose for this x0 as a grey ghost, at the first sample only (latest-at
        # keeps it for the rest of the path); an empty row clears it when no seat exists.
        target = _target_outline(d, k, prediction.x0)
        rec.send_columns(
            f"{e}/scene/target/layer{k}",
            indexes=first,
            columns=rr.LineStrips2D.columns(strips=list(target)).partition([len(target)]),
        )
    return base_d, moving_d


def _target_outline(d: FaceDesign, k: int, x0: float) -> FloatArray:
    """Layer k of the moving part seated at this x0, as a (1, v + 1, 2) closed outline in the
    design's unit; (0, 0, 2) when no seated pose exists (|x0| > L)."""
    w = d.width
    if abs(x0) > d.mated_distance * w:
        return np.zeros((0, 0, 2))
    phi = np.array([d.seated_angle(x0)])
    y_seat = d.mated_distance * np.cos(phi)
    return _closed(d.moving_outline_path(k, x0 / w, y_seat, phi)) * w


def _log_pivots(
    rec: rr.RecordingStream,
    e: str,
    x0: float,
    y_m: FloatArray,
    idx: list[rr.TimeColumn],
    first: list[rr.TimeColumn],
) -> None:
    """Base pivot (the origin) and moving pivot (x0, y_m) per sample; the moving pivot's
    whole path as one line at the first sample (``first``)."""
    n = y_m.size
    track = np.column_stack((np.full(n, x0), y_m))
    rec.send_columns(
        f"{e}/scene/pivot_path",
        indexes=first,
        columns=rr.LineStrips2D.columns(strips=[track]).partition([1]),
    )
    pivots = np.zeros((n, 2, 2))
    pivots[:, 1, 0] = x0
    pivots[:, 1, 1] = y_m
    rec.send_columns(
        f"{e}/scene/pivots",
        indexes=idx,
        columns=rr.Points2D.columns(positions=pivots.reshape(-1, 2)).partition(np.full(n, 2)),
    )


def _log_contacts(
    rec: rr.RecordingStream,
    e: str,
    prediction: Prediction,
    n: int,
    has_path: bool,
    idx: list[rr.TimeColumn],
) -> None:
    """Active contact points and their drawn normals per sample (n samples)."""
    points, arrows = _contacts(prediction, n, has_path)
    counts = [p.shape[0] for p in points]
    rec.send_columns(
        f"{e}/scene/contacts",
        indexes=idx,
        columns=rr.Points2D.columns(positions=_stack2(points)).partition(counts),
    )
    rec.send_columns(
        f"{e}/scene/normals",
        indexes=idx,
        columns=rr.Arrows2D.columns(origins=_stack2(points), vectors=_stack2(arrows)).partition(
            counts
        ),
    )


def _log_series(
    rec: rr.RecordingStream,
    e: str,
    phase: npt.NDArray[np.int64],
    series: dict[str, FloatArray],
    idx: list[rr.TimeColumn],
) -> None:
    """The phase as a state per sample, and each named series as scalars per sample."""
    rec.send_columns(
        f"{e}/phase",
        indexes=idx,
        columns=rr.StateChange.columns(state=[Phase(int(p)).name for p in phase]),
    )
    for name, values in series.items():
        rec.send_columns(
            f"{e}/series/{name}", indexes=idx, columns=rr.Scalars.columns(scalars=values)
        )


def _stack2(arrays: Sequence[FloatArray]) -> FloatArray:
    return np.vstack(arrays) if arrays else np.zeros((0, 2))


def _contacts(
    prediction: Prediction, n: int, has_path: bool
) -> tuple[list[FloatArray], list[FloatArray]]:
    """Contact points and drawn normal vectors per sample ((k, 2) each, k may be 0)."""
    empty = np.zeros((0, 2))
    if not has_path or prediction.path is None:
        return [empty] * n, [empty] * n
    scale = _NORMAL_LENGTH_D * prediction.design.width
    points: list[FloatArray] = []
    arrows: list[FloatArray] = []
    active = np.any(np.asarray(prediction.path.contact_pairs) >= 0, axis=1)
    for i in range(n):
        if not active[i]:  # no contact: skip the geometry call
            points.append(empty)
            arrows.append(empty)
            continue
        p, nrm = prediction.contact_points(i)
        points.append(np.asarray(p, dtype=np.float64).reshape(-1, 2))
        arrows.append(np.asarray(nrm, dtype=np.float64).reshape(-1, 2) * scale)
    return points, arrows


def _log_text(
    rec: rr.RecordingStream,
    e: str,
    prediction: Prediction,
    phase: npt.NDArray[np.int64],
    descent: FloatArray,
    ros_stamp_ns: int | None,
) -> None:
    """Text log rows: the query at step 0, each phase change, the outcome at the last step."""
    n = phase.size
    rows: list[int] = [0]
    query = (
        f"prediction: x0 = {prediction.x0:.6g}, theta0 = {prediction.theta0:.6g} rad "
        f"({math.degrees(prediction.theta0):.4g} deg), y_start = {prediction.y_start:.6g}"
    )
    texts = [query]
    levels = ["DEBUG"]
    for i in range(n):
        if i == 0 or phase[i] != phase[i - 1]:
            rows.append(i)
            texts.append(f"phase {Phase(int(phase[i])).name} at descent {descent[i]:.6g}")
            levels.append("DEBUG")
    outcome = prediction.outcome
    rows.append(n - 1)
    texts.append(
        f"{outcome.name}: {prediction.reason} (phi_b = {prediction.phi_b:.6g}, "
        f"phi_m = {prediction.phi_m:.6g} rad)"
    )
    levels.append(_LEVELS.get(outcome, "WARN"))
    sel = np.asarray(rows)
    idx = [
        rr.TimeColumn("step", sequence=sel.astype(np.int64)),
        rr.TimeColumn(
            "sim_descent", duration=np.round(descent[sel] * 1e9).astype("timedelta64[ns]")
        ),
    ]
    if ros_stamp_ns is not None:
        idx.append(
            rr.TimeColumn(
                "ros2_timestamp",
                timestamp=np.full(sel.size, ros_stamp_ns, dtype=np.int64).astype("datetime64[ns]"),
            )
        )
    rec.send_columns(f"{e}/log", indexes=idx, columns=rr.TextLog.columns(text=texts, level=levels))


# --- acceptance maps --------------------------------------------------------------------------


def log_acceptance_map(
    rec: rr.RecordingStream, amap: AcceptanceMapLike, *, entity: str = "map"
) -> None:
    """Log an acceptance map statically: image, legend, grid values, guaranteed rectangle.

    The image is a :class:`rerun.SegmentationImage` of Outcome values, one pixel per grid
    cell, coloured and labelled by an annotation context on ``entity`` (the legend: hovering
    a cell shows its outcome). Like the PNG of :mod:`xface_core.viz.mapimage`, theta0 runs left
    to right and x0 bottom to top (a static mirror transform on ``{entity}/cells``); view
    coordinates are cell indices (column j, row i). The raw grid goes to ``{entity}/grid`` as
    a tensor with dimensions ("x0", "theta0") and the axes as values; a markdown summary with
    M and the counts to ``{entity}/summary``.

    Parameters
    ----------
    rec : rerun.RecordingStream
    amap : AcceptanceMapLike
    entity : str
        Root entity path.

    Raises
    ------
    XfaceValueError
        The map is malformed (see :func:`xface_core.viz.mapimage.guaranteed_cells`).
    """
    x0, theta0, outcomes = checked_grid(amap)
    rect = guaranteed_cells(amap)
    e = _root(entity)
    n, m = outcomes.shape
    colors = outcome_colors()
    rec.log(
        e,
        rr.AnnotationContext(
            [rr.AnnotationInfo(id=int(o), label=o.name, color=colors[o]) for o in Outcome]
        ),
        static=True,
    )
    # Mirror about the x axis, then shift up by n: grid row i lands on y in [-(i+1), -i] of
    # the mirrored space = [n - i - 1, n - i] after the shift, so x0 grows upwards.
    rec.log(
        f"{e}/cells",
        rr.Transform3D(
            translation=[0.0, float(n), 0.0],
            mat3x3=[[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]],
        ),
        static=True,
    )
    rec.log(f"{e}/cells/image", rr.SegmentationImage(outcomes.astype(np.uint8)), static=True)
    if rect is not None:
        r0, r1, c0, c1 = rect
        rec.log(
            f"{e}/cells/guaranteed",
            rr.Boxes2D(
                mins=[[c0, r0]],
                sizes=[[c1 - c0, r1 - r0]],
                colors=[(0, 0, 0)],
                radii=rr.Radius.ui_points(2.0),
            ),
            static=True,
        )
    else:
        rec.log(f"{e}/cells/guaranteed", rr.Clear(recursive=False), static=True)
    w = amap.design.width
    corners = [[0.5, 0.5], [m - 0.5, 0.5], [0.5, n - 0.5]]
    labels = [
        f"x0 = {x0[0] / w:.3g} D, theta0 = {math.degrees(theta0[0]):.3g} deg",
        f"theta0 = {math.degrees(theta0[-1]):.3g} deg",
        f"x0 = {x0[-1] / w:.3g} D",
    ]
    rec.log(
        f"{e}/cells/axes",
        rr.Points2D(
            corners,
            labels=labels,
            radii=rr.Radius.ui_points(1.0),
            colors=[(255, 255, 255)],
            show_labels=True,
        ),
        static=True,
    )
    rec.log(
        f"{e}/grid", rr.Tensor(outcomes.astype(np.uint8), dim_names=["x0", "theta0"]), static=True
    )
    rec.log(f"{e}/grid", rr.AnyValues(x0=x0, theta0=theta0, M=[int(amap.M)]), static=True)
    rec.log(
        f"{e}/summary",
        rr.TextDocument(_summary(amap, outcomes, rect), media_type=rr.MediaType.MARKDOWN),
        static=True,
    )


def _summary(
    amap: AcceptanceMapLike,
    outcomes: npt.NDArray[np.int64],
    rect: tuple[int, int, int, int] | None,
) -> str:
    d = amap.design
    n, m = outcomes.shape
    if d.kind == "custom":
        title = f"{d.display_name}, L = {d.mated_distance:g} D"
    else:
        title = f"{d.kind}-Face, H/D = {d.h_over_d:g}, r_p = {d.r_p:g} D"
    lines = [
        f"# {title}",
        "",
        f"**M = {int(amap.M)}** SEATED of {n} x {m} = {n * m} poses; D = {d.width:g}.",
        "",
        "| outcome | cells |",
        "|---|---|",
    ]
    lines += [f"| {o.name} | {int(np.count_nonzero(outcomes == int(o)))} |" for o in Outcome]
    lines.append("")
    if rect is None:
        lines.append("Guaranteed rectangle: none.")
    else:
        r0, r1, c0, c1 = rect
        x0 = np.asarray(amap.x0, dtype=np.float64) / d.width
        th = np.degrees(np.asarray(amap.theta0, dtype=np.float64))
        lines.append(
            f"Guaranteed rectangle: {r1 - r0} x {c1 - c0} cells, x0 / D in "
            f"[{x0[r0]:.3g}, {x0[r1 - 1]:.3g}], theta0 in [{th[c0]:.3g}, {th[c1 - 1]:.3g}] deg."
        )
    return "\n".join(lines)
