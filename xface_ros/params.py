"""The node's parameters: declaration with descriptors and ranges, validation, the config.

Every parameter is declared with a :class:`ParameterDescriptor` (description, range,
read-only flag), so rclpy itself refuses an out-of-range value at startup and at run time.
What a range cannot express (the face letter, a design the core cannot build, physics the
core does not simulate) is checked by :func:`config_from_values`, which the node calls once
after declaring and then from its ``on_set_parameters`` callback.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.node import Node
from rclpy.parameter import Parameter

from xface_core.errors import XfaceError
from xface_core.frames import DEFAULT_MAX_DISTANCE_WIDTHS, DEFAULT_MAX_TILT_RAD
from xface_core.geometry import FaceDesign, make_face
from xface_core.predict import predict

__all__ = [
    "DESIGN_PARAMETERS",
    "SPECS",
    "ConfigError",
    "NodeConfig",
    "ParamSpec",
    "config_from_values",
    "declare_parameters",
    "default_record_path",
    "descriptor",
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
        "Connector face: X (two-layer X-Face), V (gendered V-Face) or S (S-Face).",
        constraints="one of X, V, S (case-insensitive)",
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
        float_range=(0.01, 100.0),
    ),
    ParamSpec(
        "r_p",
        1.0,
        "Distance from each pivot to its profile's base line, in widths D.",
        float_range=(0.0, 100.0),
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
        "carry it and every output is expressed in it.",
        constraints="non-empty, no whitespace, no leading '/'",
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
DESIGN_PARAMETERS = frozenset({"face", "width_m", "h_over_d", "r_p", "damping_ratio", "friction"})


def descriptor(spec: ParamSpec) -> ParameterDescriptor:
    """The ROS descriptor of a parameter (its type is inferred from the default)."""
    desc = ParameterDescriptor(
        name=spec.name,
        description=spec.description,
        additional_constraints=spec.constraints,
        read_only=spec.read_only,
    )
    if spec.float_range is not None:
        low, high = spec.float_range
        desc.floating_point_range = [FloatingPointRange(from_value=low, to_value=high, step=0.0)]
    if spec.int_range is not None:
        low_i, high_i = spec.int_range
        desc.integer_range = [IntegerRange(from_value=low_i, to_value=high_i, step=1)]
    return desc


@dataclass(frozen=True)
class NodeConfig:
    """A validated, immutable snapshot of the parameters and the design built from them.

    The worker reads one snapshot per prediction, so a parameter change never mixes old and
    new values within a prediction.
    """

    face: str
    width_m: float
    h_over_d: float
    r_p: float
    damping_ratio: float
    friction: float
    base_frame: str
    input_timeout_s: float
    min_margin: float
    compute_margins: bool
    max_tilt_rad: float
    max_distance_widths: float
    max_path_poses: int
    diagnostics_period_s: float
    record: bool
    record_path: str
    record_url: str
    design: FaceDesign = field(repr=False)

    @property
    def need_margins(self) -> bool:
        """Whether streamed predictions search margins."""
        return self.compute_margins or self.min_margin > 0.0

    def values(self) -> dict[str, ParamValue]:
        """The parameter values (without the design)."""
        return {spec.name: getattr(self, spec.name) for spec in SPECS}


def default_record_path(now_s: float | None = None) -> str:
    """``xface-<YYYYmmdd-HHMMSS>.rrd`` in the working directory (local time)."""
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


def _check_physics(design: FaceDesign, damping_ratio: float, friction: float) -> None:
    """Let the core refuse what it does not simulate, with its own reason.

    A pose out of reach (x0 = 2 L) ends before any contact is computed, so this costs next
    to nothing and checks the physics arguments exactly as a prediction would.
    """
    out_of_reach = 2.0 * design.mated_distance * design.width
    try:
        predict(
            design, out_of_reach, 0.0, damping_ratio=damping_ratio, friction=friction, path=False
        )
    except XfaceError as exc:
        raise ConfigError(str(exc)) from exc


def config_from_values(values: Mapping[str, Any], *, check_physics: bool = True) -> NodeConfig:
    """Validate a full set of parameter values and build the design.

    Raises
    ------
    ConfigError
        With a message naming the parameter and the reason.
    """
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
    face = str(values["face"]).strip().upper()
    if face not in ("X", "V", "S"):
        raise ConfigError(f"face must be one of X, V, S; got {values['face']!r}")
    base_frame = str(values["base_frame"])
    if not base_frame or base_frame.startswith("/") or any(c.isspace() for c in base_frame):
        raise ConfigError(
            f"base_frame must be non-empty, without whitespace or a leading '/'; got {base_frame!r}"
        )
    width = float(values["width_m"])
    try:
        design = make_face(face, float(values["h_over_d"]), float(values["r_p"]), width=width)
    except XfaceError as exc:
        raise ConfigError(f"cannot build the {face}-Face: {exc}") from exc
    damping = float(values["damping_ratio"])
    friction = float(values["friction"])
    if check_physics:
        _check_physics(design, damping, friction)
    record_path = str(values["record_path"])
    if record_path and os.path.isdir(record_path):
        raise ConfigError(f"record_path {record_path!r} is a directory, not a file")
    return NodeConfig(
        face=face,
        width_m=width,
        h_over_d=float(values["h_over_d"]),
        r_p=float(values["r_p"]),
        damping_ratio=damping,
        friction=friction,
        base_frame=base_frame,
        input_timeout_s=float(values["input_timeout_s"]),
        min_margin=float(values["min_margin"]),
        compute_margins=bool(values["compute_margins"]),
        max_tilt_rad=float(values["max_tilt_rad"]),
        max_distance_widths=float(values["max_distance_widths"]),
        max_path_poses=int(values["max_path_poses"]),
        diagnostics_period_s=float(values["diagnostics_period_s"]),
        record=bool(values["record"]),
        record_path=record_path,
        record_url=str(values["record_url"]),
        design=design,
    )


def declare_parameters(node: Node) -> NodeConfig:
    """Declare every parameter on ``node`` and return the validated startup config.

    Overrides from ``--params-file`` / ``-p`` outside a descriptor's range make rclpy raise
    ``InvalidParameterValueException`` here; values that pass the ranges but not
    :func:`config_from_values` raise :class:`ConfigError`. Either way the node does not
    start.
    """
    node.declare_parameters(
        namespace="",
        parameters=[(spec.name, spec.default, descriptor(spec)) for spec in SPECS],
    )
    return config_from_values(current_values(node))


def current_values(node: Node) -> dict[str, ParamValue]:
    """The node's current values of every parameter in :data:`SPECS`."""
    return {spec.name: node.get_parameter(spec.name).value for spec in SPECS}


def merged_values(
    current: Mapping[str, ParamValue], changes: Sequence[Parameter]
) -> dict[str, ParamValue]:
    """``current`` with the values of ``changes`` applied (unknown names are ignored)."""
    merged = dict(current)
    for param in changes:
        if param.name in SPEC_BY_NAME:
            merged[param.name] = param.value
    return merged
