"""The node's configuration without ROS: parameter specs, validation, the immutable config.

Every parameter is described once here (:data:`SPECS`: name, default, description, range);
:mod:`xface_ros.params` turns the specs into ROS parameter descriptors. What a range cannot
express (the face letter, the frame name, a design the core cannot build, physics the core
does not simulate) is checked by :func:`config_from_values`, which the node calls once after
declaring and then from its ``on_set_parameters`` callback. Imports no rclpy, so the decision
module and its tests can use the config where ROS is not installed.
"""

from __future__ import annotations

import difflib
import math
import os
import stat
import threading
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from xface_core.errors import XfaceError
from xface_core.facefile import load_face
from xface_core.frames import DEFAULT_MAX_DISTANCE_WIDTHS, DEFAULT_MAX_TILT_RAD
from xface_core.geometry import MAX_DESIGN_RATIO, FaceDesign, make_face
from xface_core.physics import Physics

__all__ = [
    "CUSTOM_FACE",
    "DESIGN_PARAMETERS",
    "FACE_FILE_TIMEOUT_S",
    "GEOMETRY_PARAMETERS",
    "SPECS",
    "SPEC_BY_NAME",
    "ConfigError",
    "NodeConfig",
    "ParamSpec",
    "ParamValue",
    "config_from_values",
    "default_record_path",
    "load_face_file",
    "normalise_frame_id",
    "not_a_regular_file",
    "params_file_applied",
    "params_file_paths",
    "unknown_parameters_message",
]

ParamValue = bool | int | float | str


class ConfigError(ValueError):
    """A set of parameter values the node cannot run with; the message says why."""


@dataclass(frozen=True)
class ParamSpec:
    """One parameter: name, default (which also fixes its type), description and limits."""

    name: str
    default: ParamValue
    description: str
    float_range: tuple[float, float] | None = None
    int_range: tuple[int, int] | None = None
    read_only: bool = False
    constraints: str = ""


SPECS: tuple[ParamSpec, ...] = (
    ParamSpec(
        "face",
        "X",
        "Connector face: X (two-layer X-Face), V (gendered V-Face), S (S-Face), or custom "
        "(the design in face_file).",
        constraints="one of X, V, S, custom (case-insensitive)",
    ),
    ParamSpec(
        "face_file",
        "",
        "Face file (YAML, docs/facefile.md) read when face is custom: the connector's "
        "polygons, mated distance and its width D in metres (width_m, h_over_d and r_p do "
        "not apply then).",
        constraints="a readable face file when face is custom",
    ),
    ParamSpec(
        "width_m",
        0.05,
        "Face width D in metres; poses are in metres.",
        float_range=(1.0e-4, 10.0),
    ),
    ParamSpec(
        "h_over_d",
        0.25,
        "Profile height over width, H/D (dimensionless).",
        float_range=(0.01, MAX_DESIGN_RATIO),
    ),
    ParamSpec(
        "r_p",
        1.0,
        "Distance from each pivot to its profile's base line, in widths D.",
        float_range=(0.0, MAX_DESIGN_RATIO),
    ),
    ParamSpec(
        "damping_ratio",
        1.0,
        "Rotational damping of the base over that of the moving part, c_B / c_M; "
        "large values approach a base that does not turn.",
        float_range=(1.0e-3, 1.0e3),
    ),
    ParamSpec(
        "friction",
        0.0,
        "Coulomb friction coefficient at every contact between the faces (0 is the "
        "paper's frictionless model).",
        float_range=(0.0, 2.0),
    ),
    ParamSpec(
        "base_frame",
        "xface_base",
        "Frame id of the base part's pivot frame (+y out of the base face); input poses must "
        "carry it and every output is expressed in it. A leading '/' is dropped, as tf2 does.",
        constraints="non-empty, no whitespace",
    ),
    ParamSpec(
        "min_seat_probability",
        0.0,
        "For poses with a covariance (relative_pose_with_covariance): accepted also needs the "
        "seat probability under it to reach this (0 = off); not accepted, the status carries "
        "a suggested correction (suggest_dx_m, suggest_dtheta_rad).",
        float_range=(0.0, 1.0),
    ),
    ParamSpec(
        "input_timeout_s",
        0.5,
        "Streamed poses whose stamp is older than this (node clock) are reported as stale, "
        "not predicted; 0 disables the check.",
        float_range=(0.0, 3600.0),
    ),
    ParamSpec(
        "min_margin",
        0.0,
        "Margin in metres a seating pose needs to count as accepted: the smaller of the "
        "lateral margin and D times the angular margin (rad). 0 accepts every seat.",
        float_range=(0.0, 10.0),
    ),
    ParamSpec(
        "compute_margins",
        True,
        "Search the outcome margins for every streamed pose (costs extra simulations; "
        "always on when min_margin > 0).",
    ),
    ParamSpec(
        "margin_threads",
        1,
        "Threads that share each batch of margin confirmations from the atlas. The node's "
        "executor and DDS already keep cores busy: on two cores one thread answers sooner "
        "than two (docs/ros.md).",
        int_range=(1, 64),
    ),
    ParamSpec(
        "max_tilt_rad",
        DEFAULT_MAX_TILT_RAD,
        "Largest roll/pitch (tilt of the moving frame's z axis, rad) accepted as planar.",
        float_range=(0.0, 0.5),
    ),
    ParamSpec(
        "max_distance_widths",
        DEFAULT_MAX_DISTANCE_WIDTHS,
        "Poses with |x| or |y| beyond this many face widths are rejected as absurd.",
        float_range=(1.0, 1.0e5),
    ),
    ParamSpec(
        "max_path_poses",
        1000,
        "Most poses in a published path; longer simulated paths are subsampled evenly "
        "(first and last sample kept).",
        int_range=(2, 100000),
    ),
    ParamSpec(
        "diagnostics_period_s",
        1.0,
        "Period of the /diagnostics message (s).",
        float_range=(0.05, 60.0),
        read_only=True,
    ),
    ParamSpec(
        "atlas_cache_dir",
        "",
        "Directory where the node keeps its acceptance atlases (atlas-<key>.npz, keyed by "
        "design geometry and physics), so a restart loads rather than rebuilds one; a "
        "leading ~ is expanded; empty = rebuild at every start.",
        constraints="empty, or a directory that exists or can be created (not a file)",
        read_only=True,
    ),
    ParamSpec(
        "record",
        False,
        "Write a rerun recording (.rrd) of every streamed prediction; finished on shutdown.",
        read_only=True,
    ),
    ParamSpec(
        "record_path",
        "",
        "Where the .rrd recording goes; empty = xface-<YYYYmmdd-HHMMSS>.rrd in the node's "
        "working directory.",
        read_only=True,
    ),
    ParamSpec(
        "record_url",
        "",
        "Also stream the recording to a live rerun viewer at this gRPC URL "
        "(e.g. rerun+http://127.0.0.1:9876/proxy); empty = none.",
        read_only=True,
    ),
)

SPEC_BY_NAME: dict[str, ParamSpec] = {spec.name: spec for spec in SPECS}

#: Parameters that change the simulated connector (the design is rebuilt from them).
DESIGN_PARAMETERS = frozenset(
    {"face", "face_file", "width_m", "h_over_d", "r_p", "damping_ratio", "friction"}
)

#: Parameters the design's geometry is read or built from. A change that sets none of them
#: keeps the design the node has: a face file is read when ``face`` or ``face_file`` is set
#: (set ``face_file`` again, even to the same path, to read an edited file), not when
#: friction or a timeout changes.
GEOMETRY_PARAMETERS = frozenset({"face", "face_file", "width_m", "h_over_d", "r_p"})

#: The ``face`` value that takes the design from ``face_file``.
CUSTOM_FACE = "custom"


@dataclass(frozen=True)
class NodeConfig:
    """A validated, immutable snapshot of the parameters and the design built from them.

    Lengths in metres, angles in radians, times in seconds. The worker reads one snapshot
    per prediction, so a parameter change never mixes old and new values within a
    prediction.
    """

    face: str
    face_file: str
    width_m: float
    """The face width D (m): the face file's for a custom face."""
    h_over_d: float
    r_p: float
    base_frame: str
    input_timeout_s: float
    min_seat_probability: float
    min_margin: float
    compute_margins: bool
    margin_threads: int
    max_tilt_rad: float
    max_distance_widths: float
    max_path_poses: int
    diagnostics_period_s: float
    atlas_cache_dir: str
    record: bool
    record_path: str
    record_url: str
    design: FaceDesign = field(repr=False)
    physics: Physics
    """Damping ratio and friction, validated by the core's own value type."""

    @property
    def damping_ratio(self) -> float:
        """c_B / c_M, as in :attr:`physics`."""
        return self.physics.damping_ratio

    @property
    def friction(self) -> float:
        """The Coulomb friction coefficient, as in :attr:`physics`."""
        return self.physics.friction

    @property
    def need_margins(self) -> bool:
        """Whether streamed predictions search margins."""
        return self.compute_margins or self.min_margin > 0.0

    def values(self) -> dict[str, ParamValue]:
        """The parameter values (without the design)."""
        return {spec.name: getattr(self, spec.name) for spec in SPECS}


def default_record_path(now_s: float | None = None) -> str:
    """``xface-<YYYYmmdd-HHMMSS>.rrd`` in the working directory (local time; ``now_s`` in s
    since the epoch, None = now)."""
    stamp = time.strftime("%Y%m%d-%H%M%S", time.localtime(now_s))
    return str(Path.cwd() / f"xface-{stamp}.rrd")


def _check_type(name: str, value: object) -> None:
    default = SPEC_BY_NAME[name].default
    # bool is an int in Python: compare the exact types; ints are fine for doubles.
    expected: tuple[type, ...] = (float, int) if type(default) is float else (type(default),)
    if type(value) not in expected:
        raise ConfigError(
            f"{name} must be a {type(default).__name__}, got {type(value).__name__} {value!r}"
        )


def _check_types_and_ranges(values: Mapping[str, Any]) -> None:
    """Every parameter present, of its type and inside its declared range."""
    missing = [spec.name for spec in SPECS if spec.name not in values]
    if missing:
        raise ConfigError(f"missing parameters: {', '.join(missing)}")
    for spec in SPECS:
        value = values[spec.name]
        _check_type(spec.name, value)
        if spec.float_range is not None:
            low, high = spec.float_range
            if not (math.isfinite(value) and low <= value <= high):
                raise ConfigError(f"{spec.name} = {value!r} is outside [{low:g}, {high:g}]")
        if spec.int_range is not None:
            low_i, high_i = spec.int_range
            if not low_i <= value <= high_i:
                raise ConfigError(f"{spec.name} = {value!r} is outside [{low_i}, {high_i}]")


def _face_letter(value: Any) -> str:
    face = str(value).strip().upper()
    if face == CUSTOM_FACE.upper():
        return CUSTOM_FACE
    if face not in ("X", "V", "S"):
        raise ConfigError(f"face must be one of X, V, S, custom; got {value!r}")
    return face


def normalise_frame_id(frame_id: str) -> str:
    """A frame id as tf2 compares it: without leading slashes (``/xface_base`` is
    ``xface_base``; tf2 frame ids carry no slash, ROS 1 style ids did).

    >>> normalise_frame_id("/xface_base")
    'xface_base'
    """
    return frame_id.lstrip("/")


def _base_frame(value: Any) -> str:
    frame = normalise_frame_id(str(value))
    if not frame or any(c.isspace() for c in frame):
        raise ConfigError(f"base_frame must be non-empty and without whitespace; got {value!r}")
    return frame


# --- face files: read with a time bound, every failure a refusal ------------------------------

#: The longest the node waits for a face file to load (s) before refusing it. The read runs on
#: a thread of its own, so the executor (services, parameters, diagnostics) waits at most this
#: long on a file that blocks (a path swapped for a FIFO after the check below, a hung network
#: mount) or takes long to parse (a deeply nested file takes seconds to refuse).
FACE_FILE_TIMEOUT_S = 10.0

#: Held while a face file is read; a read that timed out keeps it until it ends, so a file
#: that never ends ties up one thread at most, however often it is set again.
_face_file_reading = threading.Lock()

#: The longest reason (characters) quoted from an unexpected exception.
_REASON_CHARS = 300


def not_a_regular_file(path: str) -> str | None:
    """What ``path`` is, in words ("a FIFO", "a character device", ...), when it exists and is
    not a regular file; None for a regular file and for a path that cannot be stat-ed (its
    reader then says why). ``stat`` neither opens the file nor blocks, where opening a FIFO
    blocks until a writer comes and reading a device such as /dev/zero never ends.

    >>> not_a_regular_file("/dev/null")
    'a character device'
    """
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):  # ValueError: a NUL in the path
        return None
    if stat.S_ISREG(mode):
        return None
    kinds = (
        (stat.S_ISDIR, "a directory"),
        (stat.S_ISFIFO, "a FIFO"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    )
    return next((name for is_kind, name in kinds if is_kind(mode)), "a special file")


def _one_line(text: str, max_chars: int | None = None) -> str:
    """``text`` on one line (yaml's messages span several), cut to ``max_chars``."""
    line = " ".join(text.split())
    if max_chars is not None and len(line) > max_chars:
        line = line[: max_chars - 3] + "..."
    return line


def _load_failure(path: str, exc: BaseException) -> ConfigError:
    """The refusal for a face file the loader raised ``exc`` on, in one line."""
    if isinstance(exc, XfaceError):  # the core's own reason, which names the file
        return ConfigError(f"face_file: {_one_line(str(exc))}")
    if isinstance(exc, RecursionError):
        why = "it is nested too deeply to read"
    elif isinstance(exc, MemoryError):
        why = "it is too large to read (out of memory)"
    else:
        text = _one_line(str(exc), _REASON_CHARS)
        why = f"{type(exc).__name__}: {text}" if text else type(exc).__name__
    return ConfigError(f"face_file: cannot load the face file {path!r}: {why}")


def load_face_file(path: str, *, timeout_s: float | None = None) -> FaceDesign:
    """The design in the face file ``path``, read with a time bound; every failure a
    :class:`ConfigError` whose message starts ``face_file:`` and gives the reason.

    Refused: a path that is not a regular file (at once, without opening it), a read that is
    not over after ``timeout_s`` (s; None: :data:`FACE_FILE_TIMEOUT_S`), an earlier timed-out
    read still running, and anything the loader raises.
    """
    if timeout_s is None:
        timeout_s = FACE_FILE_TIMEOUT_S
    kind = not_a_regular_file(path)
    if kind is not None:
        raise ConfigError(
            f"face_file: {path!r} is {kind}, not a regular file: a face file is a YAML file "
            "(docs/facefile.md)"
        )
    if not _face_file_reading.acquire(blocking=False):
        raise ConfigError(
            f"face_file: an earlier face file is still being read (it took more than "
            f"{timeout_s:g} s); {path!r} is not read until it ends"
        )
    outcome: list[FaceDesign | BaseException] = []

    def read() -> None:
        try:
            outcome.append(load_face(path))
        # Broad on purpose: this is the node's boundary with a user's file. load_face raises
        # FaceFileError for what it knows, but yaml and the checks under it can raise anything
        # (RecursionError on deep nesting, ValueError on a 5,000-digit number, MemoryError,
        # OSError...), and an exception here would otherwise end the node.
        except Exception as exc:
            outcome.append(exc)
        finally:
            _face_file_reading.release()

    reader = threading.Thread(target=read, name="xface_face_file", daemon=True)
    try:
        reader.start()
    except RuntimeError as exc:  # no thread to be had: nothing was read
        _face_file_reading.release()
        raise ConfigError(f"face_file: cannot read {path!r} now: {exc}") from exc
    reader.join(timeout_s)
    if not outcome:
        raise ConfigError(
            f"face_file: reading the face file {path!r} took more than {timeout_s:g} s"
        )
    result = outcome[0]
    if isinstance(result, BaseException):
        raise _load_failure(path, result) from result
    return result


def _design(face: str, values: Mapping[str, Any]) -> FaceDesign:
    """The connector in metres, or the core's reason why it cannot exist."""
    if face == CUSTOM_FACE:
        path = str(values["face_file"])
        if not path:
            raise ConfigError("face custom needs face_file: the path of a face file")
        return load_face_file(path)
    try:
        return make_face(
            face, float(values["h_over_d"]), float(values["r_p"]), width=float(values["width_m"])
        )
    except XfaceError as exc:
        raise ConfigError(f"cannot build the {face}-Face: {exc}") from exc


def _physics(values: Mapping[str, Any]) -> Physics:
    """The core's physics value; its own message (naming the field) when it refuses."""
    try:
        return Physics(
            damping_ratio=float(values["damping_ratio"]), friction=float(values["friction"])
        )
    except XfaceError as exc:
        raise ConfigError(str(exc)) from exc


def _record_path(value: Any) -> str:
    path = str(value)
    if path and os.path.isdir(path):
        raise ConfigError(f"record_path {path!r} is a directory, not a file")
    return path


def _atlas_cache_dir(value: Any) -> str:
    path = str(value)
    if path and Path(path).expanduser().exists() and not Path(path).expanduser().is_dir():
        raise ConfigError(f"atlas_cache_dir {path!r} is a file, not a directory")
    return path


def config_from_values(
    values: Mapping[str, Any], *, design: FaceDesign | None = None
) -> NodeConfig:
    """Validate a full set of parameter values and build the design and the physics.

    ``design``, when given, is kept instead of built: the design the node has, for a change
    that sets none of :data:`GEOMETRY_PARAMETERS` (the values' geometry is the one it was
    built from). No face file is read then.

    Raises
    ------
    ConfigError
        With a message naming the parameter and the reason.
    """
    _check_types_and_ranges(values)
    face = _face_letter(values["face"])
    base_frame = _base_frame(values["base_frame"])
    if design is None:
        design = _design(face, values)
    physics = _physics(values)
    record_path = _record_path(values["record_path"])
    return NodeConfig(
        face=face,
        face_file=str(values["face_file"]),
        width_m=design.width,
        h_over_d=float(values["h_over_d"]),
        r_p=float(values["r_p"]),
        base_frame=base_frame,
        input_timeout_s=float(values["input_timeout_s"]),
        min_seat_probability=float(values["min_seat_probability"]),
        min_margin=float(values["min_margin"]),
        compute_margins=bool(values["compute_margins"]),
        margin_threads=int(values["margin_threads"]),
        max_tilt_rad=float(values["max_tilt_rad"]),
        max_distance_widths=float(values["max_distance_widths"]),
        max_path_poses=int(values["max_path_poses"]),
        diagnostics_period_s=float(values["diagnostics_period_s"]),
        atlas_cache_dir=_atlas_cache_dir(values["atlas_cache_dir"]),
        record=bool(values["record"]),
        record_path=record_path,
        record_url=str(values["record_url"]),
        design=design,
        physics=physics,
    )


# --- does a --params-file reach the node? ----------------------------------------------------


def params_file_paths(argv: Sequence[str]) -> list[str]:
    """The ``--params-file`` paths among the ROS arguments of a command line.

    ROS arguments run from ``--ros-args`` to ``--`` (or the end); there may be several such
    sections.

    >>> params_file_paths(["prog", "--ros-args", "-r", "__ns:=/left", "--params-file", "a.yaml"])
    ['a.yaml']
    >>> params_file_paths(["prog", "--params-file", "x.yaml"])  # not a ROS argument
    []
    """
    paths: list[str] = []
    in_ros_args = False
    args = list(argv)
    for i, arg in enumerate(args):
        if arg == "--ros-args":
            in_ros_args = True
        elif arg == "--":
            in_ros_args = False
        elif in_ros_args and arg == "--params-file" and i + 1 < len(args):
            paths.append(args[i + 1])
    return paths


def params_file_applied(
    file_values: Mapping[str, object], node_overrides: Mapping[str, object]
) -> bool:
    """Whether any of this node's parameters in a params file reached the node.

    ``file_values`` are the file's parameters under every node key it has, ``node_overrides``
    the overrides rcl matched to this node (its name and namespace against the file's keys).
    A file whose keys name another node (``xface_predictor:`` for a node renamed
    ``dock_left``) gives the node none of its values: the node then runs on its defaults,
    which is worth a warning.

    >>> params_file_applied({"width_m": 0.1}, {"width_m": 0.1})
    True
    >>> params_file_applied({"width_m": 0.1}, {})
    False
    >>> params_file_applied({"use_sim_time": True}, {"use_sim_time": True})
    True
    """
    # Any parameter counts, ours or rclpy's own (a file may set only use_sim_time).
    return any(
        name in node_overrides and node_overrides[name] == value
        for name, value in file_values.items()
    )


# --- parameters the node does not have ------------------------------------------------------


def unknown_parameters_message(names: Iterable[str], known: Iterable[str]) -> str | None:
    """One warning line for parameters set for the node (params file, ``-p``) that it does not
    have, each with the closest known name when one is close (None: every name is known).

    rclpy drops such an override without a word, so a misspelt name would silently leave its
    parameter at the default.

    >>> unknown_parameters_message(["widht_m", "face"], ["face", "width_m"])
    'unknown parameters, ignored: widht_m (did you mean width_m?)'
    >>> unknown_parameters_message(["face"], ["face"]) is None
    True
    """
    known_names = sorted(set(known))
    unknown = sorted(set(names) - set(known_names))
    if not unknown:
        return None
    described = []
    for name in unknown:
        close = difflib.get_close_matches(name, known_names, n=1)
        described.append(f"{name} (did you mean {close[0]}?)" if close else name)
    return f"unknown parameters, ignored: {', '.join(described)}"
