"""Rerun recordings: real .rrd files written, read back with rerun.chunk.RrdReader, checked
against the Prediction or map they came from, and checked by the `rerun rrd` CLI."""

from __future__ import annotations

import math
import os
import signal
import socket
import subprocess
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
import rerun as rr
from rerun.chunk import RrdReader

from xface_core.codes import Outcome
from xface_core.errors import XfaceValueError
from xface_core.geometry import FaceDesign, v_face, x_face
from xface_core.maps.acceptance import AcceptanceMap, acceptance_map
from xface_core.predict import predict
from xface_core.result import AlignmentPath, Counters, Phase, Prediction
from xface_core.viz.mapimage import outcome_colors
from xface_core.viz.recording import (
    default_blueprint,
    log_acceptance_map,
    log_design,
    log_prediction,
    log_verdict,
    new_recording,
)

RERUN_CLI = Path(sys.executable).with_name("rerun")

#: Runs the command after it with SIGINT at its default disposition: a suite started from a
#: background job of a shell without job control inherits SIGINT ignored, and so would the
#: child (Python and the rerun CLI keep an inherited ignore), never seeing our Ctrl-C.
_RESET_SIGINT = "import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_DFL); "
DEFAULT_SIGINT = [sys.executable, "-c", _RESET_SIGINT + "os.execvp(sys.argv[1], sys.argv[1:])"]

STAMP_NS = 1_700_000_000_123_456_789


# --- building inputs ----------------------------------------------------------------------------


def approach_only(design: FaceDesign, x0: float, theta0: float, *, n: int = 6) -> Prediction:
    """A hand-made prediction: the moving part comes down from 0.5 D above the seat height
    and stops 0.2 D above it without touching (angles frozen, no contacts)."""
    w = design.width
    y_start = (design.mated_distance + 0.5) * w
    descent = np.linspace(0.0, 0.3 * w, n)
    path = AlignmentPath(
        descent=descent,
        phi_b=np.zeros(n),
        phi_m=np.full(n, theta0),
        pivot_m=np.column_stack((np.full(n, x0), y_start - descent)),
        phase=np.full(n, int(Phase.APPROACH), dtype=np.int64),
        contact_pairs=np.full((n, 4), -1, dtype=np.int64),
    )
    return Prediction(
        design=design,
        x0=x0,
        theta0=theta0,
        y_start=y_start,
        outcome=Outcome.NO_CONTACT,
        reason="hand-made: the parts never touch",
        phi_b=0.0,
        phi_m=theta0,
        pivot_m=(x0, float(y_start - descent[-1])),
        counters=Counters(steps=n, events=0, contact_changes=0),
        path=path,
    )


@pytest.fixture(scope="module")
def seated() -> Prediction:
    """A real X-Face prediction that touches, aligns and seats."""
    p = predict(x_face(0.25, 2.0), 0.3, 0.2)
    assert p.outcome is Outcome.SEATED
    return p


def path_of(p: Prediction) -> AlignmentPath:
    assert p.path is not None
    return p.path


def record(tmp_path: Path, prediction: Prediction, name: str = "rec.rrd", **kwargs: Any) -> Path:
    path = tmp_path / name
    rec = new_recording(recording_id="xface-test", path=path)
    log_prediction(rec, prediction, **kwargs)
    rec.disconnect()
    return path


def chunks(path: Path, entity: str, *, static: bool = False) -> list[Any]:
    """Record batches of one entity, temporal (sorted by step) or static."""
    found = [
        c.to_record_batch()
        for c in RrdReader(path).store().stream()
        if c.entity_path == entity and c.is_static == static
    ]
    if not static and all("step" in rb.schema.names for rb in found):
        found.sort(key=lambda rb: rb.column("step")[0].as_py())
    return found


def column(path: Path, entity: str, component: str, *, static: bool = False) -> list[Any]:
    return [
        v for rb in chunks(path, entity, static=static) for v in rb.column(component).to_pylist()
    ]


def timelines(path: Path) -> set[str]:
    return {name for c in RrdReader(path).store().stream() for name in c.timeline_names}


def rerun_cli(*args: str | Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(RERUN_CLI), *map(str, args)], capture_output=True, text=True, timeout=120
    )


# --- the prediction's values --------------------------------------------------------------------


@pytest.mark.parametrize("series", ["phi_b", "phi_m", "descent"])
def test_series_equal_the_path(tmp_path: Path, seated: Prediction, series: str) -> None:
    path = record(tmp_path, seated)
    logged = [v[0] for v in column(path, f"/xface/series/{series}", "Scalars:scalars")]
    np.testing.assert_array_equal(logged, getattr(path_of(seated), series))


def test_one_row_per_path_sample(tmp_path: Path, seated: Prediction) -> None:
    path = record(tmp_path, seated)
    rows = column(path, "/xface/scene/moving/layer0", "LineStrips2D:strips")
    assert len(rows) == len(path_of(seated))


def test_step_timeline_numbers_the_samples(tmp_path: Path, seated: Prediction) -> None:
    path = record(tmp_path, seated)
    steps = column(path, "/xface/series/phi_m", "step")
    assert steps == list(range(len(path_of(seated))))


def test_sim_descent_timeline_is_the_descent(tmp_path: Path, seated: Prediction) -> None:
    path = record(tmp_path, seated)
    rb = chunks(path, "/xface/series/phi_m")[0]
    ns = np.array(rb.column("sim_descent").cast("int64").to_pylist())
    np.testing.assert_allclose(ns * 1e-9, path_of(seated).descent, rtol=0, atol=1e-9)


def test_outcome_is_the_last_text_log_line(tmp_path: Path, seated: Prediction) -> None:
    path = record(tmp_path, seated)
    last = column(path, "/xface/log", "TextLog:text")[-1][0]
    assert last.startswith(f"SEATED: {seated.reason}")


def test_every_phase_is_logged_per_sample(tmp_path: Path, seated: Prediction) -> None:
    path = record(tmp_path, seated)
    states = [v[0] for v in column(path, "/xface/phase", "StateChange:state")]
    assert states == [Phase(int(p)).name for p in path_of(seated).phase]


def test_moving_outline_is_the_world_polygon(tmp_path: Path, seated: Prediction) -> None:
    path = record(tmp_path, seated)
    i = len(path_of(seated)) // 2
    strip = np.array(column(path, "/xface/scene/moving/layer1", "LineStrips2D:strips")[i][0])
    d, p = seated.design, path_of(seated)
    expected = d.moving_outline_world(1, seated.x0, p.pivot_m[i, 1], p.phi_m[i])
    np.testing.assert_allclose(strip, np.vstack((expected, expected[:1])), atol=1e-6)


def test_lengths_are_in_the_design_unit(tmp_path: Path) -> None:
    design = v_face(1.0, 1.0, width=0.05)  # D = 5 cm, lengths in metres
    p = approach_only(design, 0.01, 0.1)
    path = record(tmp_path, p)
    last = np.array(column(path, "/xface/scene/pivots", "Points2D:positions")[-1])
    np.testing.assert_allclose(last[1], p.pivot_m, rtol=1e-6)


def test_gap_is_the_clearance_between_the_parts(tmp_path: Path) -> None:
    # Aligned V-Faces (x0 = 0, both angles 0) a height g above the seat: the flanks are
    # parallel with slope 2 H/D = 2, so the clearance is g cos(atan 2) = g / sqrt(5).
    design = v_face(1.0, 1.0)
    p = approach_only(design, 0.0, 0.0)
    path = record(tmp_path, p)
    gap = [v[0] for v in column(path, "/xface/series/gap", "Scalars:scalars")]
    above_seat = path_of(p).pivot_m[:, 1] - design.mated_distance
    np.testing.assert_allclose(gap, above_seat / math.sqrt(5.0), rtol=1e-9)


def test_gap_is_zero_when_seated(tmp_path: Path, seated: Prediction) -> None:
    path = record(tmp_path, seated)
    gap = column(path, "/xface/series/gap", "Scalars:scalars")[-1][0]
    assert gap == pytest.approx(0.0, abs=1e-6)


def test_contact_points_equal_the_prediction(tmp_path: Path, seated: Prediction) -> None:
    path = record(tmp_path, seated)
    logged = column(path, "/xface/scene/contacts", "Points2D:positions")
    expected = [seated.contact_points(i)[0] for i in range(len(path_of(seated)))]
    assert [len(p) for p in logged] == [len(p) for p in expected]
    touching = [i for i, p in enumerate(expected) if len(p)]
    for i in touching:
        np.testing.assert_allclose(np.array(logged[i]), expected[i], atol=1e-6)


def test_a_seating_dock_logs_contacts(tmp_path: Path, seated: Prediction) -> None:
    path = record(tmp_path, seated)
    logged = column(path, "/xface/scene/contacts", "Points2D:positions")
    assert any(len(p) > 0 for p in logged)


def test_normals_start_at_the_contact_points(tmp_path: Path, seated: Prediction) -> None:
    path = record(tmp_path, seated)
    points = column(path, "/xface/scene/contacts", "Points2D:positions")
    origins = column(path, "/xface/scene/normals", "Arrows2D:origins")
    assert points == origins


def test_design_is_static_and_mated(tmp_path: Path) -> None:
    design = x_face(0.5, 1.0, width=2.0)
    path = tmp_path / "design.rrd"
    rec = new_recording(recording_id="design", path=path)
    log_design(rec, design)
    rec.disconnect()
    strip = np.array(
        column(path, "/xface/design/moving/layer0", "LineStrips2D:strips", static=True)[0][0]
    )
    expected = design.moving_outline_world(0, 0.0, design.mated_distance, 0.0) * 2.0
    np.testing.assert_allclose(strip[:-1], expected, atol=1e-6)


def test_base_outline_is_the_world_polygon(tmp_path: Path, seated: Prediction) -> None:
    path = record(tmp_path, seated)
    i = len(path_of(seated)) - 1
    strip = np.array(column(path, "/xface/scene/base/layer0", "LineStrips2D:strips")[i][0])
    expected = seated.design.base_outline_world(0, path_of(seated).phi_b[i])
    np.testing.assert_allclose(strip, np.vstack((expected, expected[:1])), atol=1e-6)


def test_design_goes_in_once_per_stream(tmp_path: Path) -> None:
    design = v_face(1.0, 1.0)
    path = tmp_path / "session.rrd"
    rec = new_recording(recording_id="session", path=path)
    for x0 in (0.0, 0.1, 0.2):
        log_prediction(rec, approach_only(design, x0, 0.0))
    rec.disconnect()
    assert len(chunks(path, "/xface/design/base/layer0", static=True)) == 1


def test_a_new_design_replaces_the_old_one(tmp_path: Path) -> None:
    path = tmp_path / "session.rrd"
    rec = new_recording(recording_id="session", path=path)
    log_prediction(rec, approach_only(v_face(1.0, 1.0), 0.0, 0.0))
    taller = v_face(2.0, 1.0)
    log_prediction(rec, approach_only(taller, 0.0, 0.0))
    rec.disconnect()
    last = column(path, "/xface/design/base/layer0", "LineStrips2D:strips", static=True)[-1][0]
    expected = taller.base_outline_world(0, 0.0)
    np.testing.assert_allclose(np.array(last)[:-1], expected, atol=1e-6)


def test_prediction_without_path_is_one_sample(tmp_path: Path) -> None:
    p = replace(approach_only(v_face(1.0, 1.0), 0.1, 0.2), path=None)
    path = record(tmp_path, p)
    assert len(column(path, "/xface/scene/moving/layer0", "LineStrips2D:strips")) == 1


def test_out_of_reach_has_no_target_pose(tmp_path: Path) -> None:
    design = v_face(1.0, 0.0)  # L = 1 D
    path = record(tmp_path, approach_only(design, 1.5, 0.0))
    assert column(path, "/xface/scene/target/layer0", "LineStrips2D:strips") == [[]]


# --- timelines and determinism ------------------------------------------------------------------


def test_ros_stamp_adds_the_ros2_timestamp_timeline(tmp_path: Path, seated: Prediction) -> None:
    path = record(tmp_path, seated, ros_stamp_ns=STAMP_NS)
    rb = chunks(path, "/xface/series/phi_m")[0]
    assert set(rb.column("ros2_timestamp").cast("int64").to_pylist()) == {STAMP_NS}


def test_only_the_simulation_timelines_without_a_stamp(tmp_path: Path, seated: Prediction) -> None:
    path = record(tmp_path, seated)
    assert timelines(path) == {"step", "sim_descent"}  # no log_time, log_tick, ros2_timestamp


def test_recording_id_is_the_one_given(tmp_path: Path, seated: Prediction) -> None:
    path = record(tmp_path, seated)
    assert [s.recording_id for s in RrdReader(path).recordings()] == ["xface-test"]


def test_blueprint_is_written_by_default(tmp_path: Path, seated: Prediction) -> None:
    path = record(tmp_path, seated)
    assert len(RrdReader(path).blueprints()) == 1


def test_no_blueprint_when_asked(tmp_path: Path) -> None:
    path = tmp_path / "plain.rrd"
    rec = new_recording(recording_id="plain", path=path, blueprint=False)
    log_design(rec, v_face(1.0, 1.0))
    rec.disconnect()
    assert RrdReader(path).blueprints() == []


def test_caller_timeline_state_is_left_alone(tmp_path: Path) -> None:
    path = tmp_path / "caller.rrd"
    rec = new_recording(recording_id="caller", path=path)
    rec.set_time("frame", sequence=7)
    log_prediction(rec, approach_only(v_face(1.0, 1.0), 0.0, 0.0))
    rec.log("caller/value", rr.Scalars(1.0))
    rec.disconnect()
    assert column(path, "/caller/value", "frame") == [7]


def test_rrd_verify_accepts_a_prediction(tmp_path: Path, seated: Prediction) -> None:
    path = record(tmp_path, seated, ros_stamp_ns=STAMP_NS)
    result = rerun_cli("rrd", "verify", path)
    assert result.returncode == 0, result.stderr


def _interrupt(proc: subprocess.Popen[Any], timeout_s: float) -> None:
    """Ctrl-C to ``proc`` (started in a session of its own, through DEFAULT_SIGINT) and wait
    for it. One that does not end in time is killed with its children, so a failed test
    leaves no server behind."""
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        raise


_RECORD_AND_WAIT = """
import sys, time
from xface_core.geometry import v_face
from xface_core.predict import predict
from xface_core.viz.recording import new_recording, log_prediction
rec = new_recording(recording_id="interrupted", path=sys.argv[1])
log_prediction(rec, predict(v_face(1.0, 1.0), 0.1, 0.1))
print("recorded", flush=True)
time.sleep(120)
"""


def test_file_is_finished_after_sigint(tmp_path: Path) -> None:
    # A process interrupted without calling disconnect(): rerun finishes the file at exit.
    path = tmp_path / "interrupted.rrd"
    proc = subprocess.Popen(
        [*DEFAULT_SIGINT, sys.executable, "-c", _RECORD_AND_WAIT, str(path)],
        stdout=subprocess.PIPE,
        text=True,
        cwd=Path(__file__).resolve().parents[3],
        start_new_session=True,
    )
    try:
        assert proc.stdout is not None
        assert proc.stdout.readline().strip() == "recorded"
    finally:
        _interrupt(proc, 60.0)
    result = rerun_cli("rrd", "verify", path)
    assert result.returncode == 0, result.stderr


def test_same_prediction_compares_equal(tmp_path: Path, seated: Prediction) -> None:
    a = record(tmp_path, seated, "a.rrd")
    b = record(tmp_path, seated, "b.rrd")
    result = rerun_cli("rrd", "compare", a, b)
    assert result.returncode == 0, result.stdout + result.stderr


def test_compare_tells_different_predictions_apart(tmp_path: Path, seated: Prediction) -> None:
    a = record(tmp_path, seated, "a.rrd")
    b = record(tmp_path, replace(seated, reason="another reason"), "b.rrd")
    assert rerun_cli("rrd", "compare", a, b).returncode != 0


# --- input errors -------------------------------------------------------------------------------


@pytest.mark.parametrize("stamp", [1.5, "1700000000", True])
def test_stamp_must_be_integer_nanoseconds(tmp_path: Path, seated: Prediction, stamp: Any) -> None:
    rec = new_recording(recording_id="bad", blueprint=False)
    with pytest.raises(XfaceValueError, match="ros_stamp_ns"):
        log_prediction(rec, seated, ros_stamp_ns=stamp)


def test_nan_path_is_refused(seated: Prediction) -> None:
    bad_path = replace(path_of(seated), phi_m=np.full(len(path_of(seated)), np.nan))
    rec = new_recording(recording_id="nan", blueprint=False)
    with pytest.raises(XfaceValueError, match="NaN"):
        log_prediction(rec, replace(seated, path=bad_path))


@pytest.mark.parametrize("entity", ["", "/", "//"])
def test_an_empty_entity_is_refused(seated: Prediction, entity: str) -> None:
    rec = new_recording(recording_id="root", blueprint=False)
    with pytest.raises(XfaceValueError, match="entity"):
        log_prediction(rec, seated, entity=entity)


def test_another_entity_holds_the_tree(tmp_path: Path, seated: Prediction) -> None:
    path = record(tmp_path, seated, entity="/robot/dock/")
    logged = [v[0] for v in column(path, "/robot/dock/series/phi_m", "Scalars:scalars")]
    np.testing.assert_array_equal(logged, path_of(seated).phi_m)


def test_blueprint_argument_is_checked() -> None:
    with pytest.raises(XfaceValueError, match="blueprint"):
        new_recording(blueprint="yes")


def test_blueprint_tab_name_is_checked() -> None:
    with pytest.raises(XfaceValueError, match="active"):
        default_blueprint(active="table")


# --- live viewer over gRPC (loopback only) ------------------------------------------------------


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _wait_for_port(port: int, proc: subprocess.Popen[bytes], timeout_s: float = 30.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError(f"rerun exited early with {proc.returncode}")
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return
        time.sleep(0.1)
    raise TimeoutError(f"rerun did not listen on 127.0.0.1:{port}")


def test_url_streams_to_a_live_viewer(tmp_path: Path, seated: Prediction) -> None:
    # The rerun CLI as a headless gRPC sink that saves what it receives.
    port = _free_port()
    saved = tmp_path / "live.rrd"
    serve = [str(RERUN_CLI), "--bind", "127.0.0.1", "--port", str(port), "--save", str(saved)]
    proc = subprocess.Popen(
        [*DEFAULT_SIGINT, *serve],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    try:
        _wait_for_port(port, proc)
        rec = new_recording(recording_id="live", url=f"rerun+http://127.0.0.1:{port}/proxy")
        log_prediction(rec, seated)
        rec.flush(timeout_sec=30.0)
        rec.disconnect()
    finally:
        _interrupt(proc, 30.0)
    # The CLI's own file has no footer when interrupted (rerun warns), so read it as a stream.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        received = {
            c.entity_path
            for c in RrdReader(saved).stream().to_chunks()
            if c.entity_path.startswith("/xface/series")
        }
    assert received == {f"/xface/series/{s}" for s in ("phi_b", "phi_m", "descent", "gap")}


# --- acceptance maps ----------------------------------------------------------------------------


@pytest.fixture
def small_map() -> SimpleNamespace:
    """A hand-made 5 x 7 map: a seated block in the middle, other outcomes around it."""
    x0 = np.linspace(-1.0, 1.0, 5)
    theta0 = np.linspace(-math.pi / 2, math.pi / 2, 7)
    grid = np.full((5, 7), int(Outcome.BAD_MATE), dtype=np.int8)
    grid[1:4, 2:5] = int(Outcome.SEATED)
    grid[0, :] = int(Outcome.OUT_OF_REACH)
    grid[4, 6] = int(Outcome.PASSED)
    return SimpleNamespace(
        x0=x0,
        theta0=theta0,
        outcomes=grid,
        M=9,
        design=x_face(0.25, 1.0),
        guaranteed=(slice(1, 4), slice(2, 5)),
    )


def record_map(tmp_path: Path, amap: Any) -> Path:
    path = tmp_path / "map.rrd"
    rec = new_recording(recording_id="map", path=path, blueprint=default_blueprint(active="map"))
    log_acceptance_map(rec, amap)
    rec.disconnect()
    return path


def map_image(path: Path) -> np.ndarray[Any, np.dtype[np.uint8]]:
    """The segmentation image of a map recording, as the (rows, columns) array it holds."""
    rb = chunks(path, "/map/cells/image", static=True)[0]
    fmt = rb.column("SegmentationImage:format").to_pylist()[0][0]
    buffer = bytes(rb.column("SegmentationImage:buffer").to_pylist()[0][0])
    return np.frombuffer(buffer, dtype=np.uint8).reshape(fmt["height"], fmt["width"])


def test_map_image_holds_the_outcomes(tmp_path: Path, small_map: SimpleNamespace) -> None:
    image = map_image(record_map(tmp_path, small_map))
    np.testing.assert_array_equal(image, small_map.outcomes)


def test_map_legend_labels_every_outcome(tmp_path: Path, small_map: SimpleNamespace) -> None:
    path = record_map(tmp_path, small_map)
    context = column(path, "/map", "AnnotationContext:context", static=True)[0][0]
    labels = {entry["class_id"]: entry["class_description"]["info"]["label"] for entry in context}
    assert labels == {int(o): o.name for o in Outcome}


def test_map_legend_colours_are_the_png_colours(tmp_path: Path, small_map: SimpleNamespace) -> None:
    path = record_map(tmp_path, small_map)
    context = column(path, "/map", "AnnotationContext:context", static=True)[0][0]
    packed = {entry["class_id"]: entry["class_description"]["info"]["color"] for entry in context}
    expected = {
        int(o): (r << 24) | (g << 16) | (b << 8) | 0xFF for o, (r, g, b) in outcome_colors().items()
    }
    assert packed == expected


def test_map_guaranteed_box_covers_the_rectangle(
    tmp_path: Path, small_map: SimpleNamespace
) -> None:
    path = record_map(tmp_path, small_map)
    rb = chunks(path, "/map/cells/guaranteed", static=True)[0]
    half = np.array(rb.column("Boxes2D:half_sizes").to_pylist()[0][0])
    center = np.array(rb.column("Boxes2D:centers").to_pylist()[0][0])
    # columns 2:5 along x, rows 1:4 along y, in cell units
    np.testing.assert_allclose(center - half, [2.0, 1.0])
    np.testing.assert_allclose(center + half, [5.0, 4.0])


def test_map_tensor_holds_the_grid(tmp_path: Path, small_map: SimpleNamespace) -> None:
    path = record_map(tmp_path, small_map)
    rb = chunks(path, "/map/grid", static=True)
    tensor = next(b for b in rb if "Tensor:data" in b.schema.names).column("Tensor:data")
    data = tensor.to_pylist()[0][0]
    shape = [int(s) for s in data["shape"]]
    values = np.array(data["buffer"]["U8"] if isinstance(data["buffer"], dict) else data["buffer"])
    np.testing.assert_array_equal(values.reshape(shape), small_map.outcomes)


def test_map_recording_passes_rrd_verify(tmp_path: Path, small_map: SimpleNamespace) -> None:
    path = record_map(tmp_path, small_map)
    result = rerun_cli("rrd", "verify", path)
    assert result.returncode == 0, result.stderr


def test_map_with_inconsistent_rectangle_is_refused(small_map: SimpleNamespace) -> None:
    small_map.guaranteed = (slice(0, 2), slice(0, 2))  # covers OUT_OF_REACH cells
    rec = new_recording(recording_id="bad-map", blueprint=False)
    with pytest.raises(XfaceValueError, match="not SEATED"):
        log_acceptance_map(rec, small_map)


def test_rerun_cli_is_the_wheels() -> None:
    # The CLI the tests call is the one shipped in the rerun-sdk wheel, beside this Python.
    assert rerun_cli("--version").stdout.split()[1] == rr.__version__


# --- cost (timed only with --benchmark-enable) --------------------------------------------------


def test_log_prediction_benchmark(benchmark: Any, tmp_path: Path, seated: Prediction) -> None:
    # One real X-Face prediction per call into one file, as the node records a session.
    # Timed: pytest tests/core/viz/test_recording.py -k benchmark --benchmark-enable
    path = tmp_path / "bench.rrd"
    rec = new_recording(recording_id="bench", path=path)
    benchmark(log_prediction, rec, seated, ros_stamp_ns=STAMP_NS)
    rec.disconnect()
    assert len(column(path, "/xface/series/phi_m", "Scalars:scalars")) >= len(path_of(seated))


# --- a real acceptance map ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def real_map() -> AcceptanceMap:
    amap = acceptance_map(x_face(0.25, 0.25), grid=11)
    assert amap.guaranteed is not None
    return amap


def test_real_map_image_holds_its_outcomes(tmp_path: Path, real_map: AcceptanceMap) -> None:
    image = map_image(record_map(tmp_path, real_map))
    np.testing.assert_array_equal(image, real_map.outcomes)


def test_real_map_summary_states_m(tmp_path: Path, real_map: AcceptanceMap) -> None:
    path = record_map(tmp_path, real_map)
    text = column(path, "/map/summary", "TextDocument:text", static=True)[0][0]
    assert f"**M = {real_map.M}**" in text


def test_real_map_recording_passes_rrd_verify(tmp_path: Path, real_map: AcceptanceMap) -> None:
    result = rerun_cli("rrd", "verify", record_map(tmp_path, real_map))
    assert result.returncode == 0, result.stderr


# --- what a reviewer reads off a node's recording ------------------------------------------------


def test_the_pivot_path_is_the_moving_pivots_track(tmp_path: Path, seated: Prediction) -> None:
    path = record(tmp_path, seated)
    [[strip]] = column(path, "/xface/scene/pivot_path", "LineStrips2D:strips")  # one row, one strip
    track = np.asarray(strip)
    assert np.allclose(track[:, 0], seated.x0)
    assert np.allclose(track[:, 1], path_of(seated).pivot_m[:, 1])


def test_the_design_is_stored_as_values(tmp_path: Path) -> None:
    design = v_face(0.5, 1.0, width=0.05)
    path = record(tmp_path, predict(design, 0.01, 0.1))
    assert column(path, "/xface/design/values", "face", static=True) == [["V"]]
    assert column(path, "/xface/design/values", "h_over_d", static=True) == [[0.5]]
    [[mated]] = column(path, "/xface/design/values", "mated_distance", static=True)
    assert mated == pytest.approx(design.mated_distance * 0.05)


def _verdicts(tmp_path: Path, predictions: list[tuple[Prediction, bool]]) -> Path:
    path = tmp_path / "node.rrd"
    rec = new_recording(recording_id="xface-test", path=path)
    for k, (p, accepted) in enumerate(predictions):
        log_verdict(rec, p, accepted=accepted, ros_stamp_ns=STAMP_NS + k * 1_000_000)
    rec.disconnect()
    return path


def test_verdicts_are_one_row_per_prediction_on_the_ros_timeline(tmp_path: Path) -> None:
    design = x_face(0.25, 2.0)
    runs = [(predict(design, 0.3, 0.2, margins=True), True), (predict(design, 0.9, 0.8), False)]
    path = _verdicts(tmp_path, runs)
    codes = [v[0] for v in column(path, "/xface/verdict/outcome_code", "Scalars:scalars")]
    assert codes == [float(p.outcome) for p, _ in runs]
    accepted = [v[0] for v in column(path, "/xface/verdict/accepted", "Scalars:scalars")]
    assert accepted == [1.0, 0.0]
    x0 = [v[0] for v in column(path, "/xface/verdict/input/x0", "Scalars:scalars")]
    assert x0 == [0.3, 0.9]
    assert "ros2_timestamp" in timelines(path)
    assert "step" not in timelines(path)


def test_verdict_margins_are_the_predictions_margins(tmp_path: Path) -> None:
    p = predict(x_face(0.25, 2.0), 0.3, 0.2, margins=True)
    assert p.margins is not None
    path = _verdicts(tmp_path, [(p, True)])
    [[angle]] = column(path, "/xface/verdict/margin/angle_plus", "Scalars:scalars")
    assert angle == p.margins.angle_plus


def test_a_verdict_needs_its_stamp(seated: Prediction) -> None:
    with pytest.raises(XfaceValueError, match="ros_stamp_ns"):
        log_verdict(new_recording(), seated, accepted=True, ros_stamp_ns=None)  # type: ignore[arg-type]


def test_the_node_tab_opens_on_the_ros_timeline() -> None:
    assert type(default_blueprint(active="node")).__name__ == "Blueprint"
