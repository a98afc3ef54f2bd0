"""The node's ROS parameters: declaration with descriptors and ranges, reading, merging.

The parameter handler of the node (as nav2's docking server keeps its ``ParameterHandler``
apart from the server). Every parameter is declared with a :class:`ParameterDescriptor`
(description, range, read-only flag) built from :data:`xface_ros.config.SPECS`, so rclpy
itself refuses an out-of-range value at startup and at run time. What a range cannot express
is checked by :func:`xface_ros.config.config_from_values` (ROS-free, re-exported here), which
builds the immutable :class:`~xface_ros.config.NodeConfig` the node runs with.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.node import Node
from rclpy.parameter import Parameter

from xface_ros.config import (
    DESIGN_PARAMETERS,
    GEOMETRY_PARAMETERS,
    SPEC_BY_NAME,
    SPECS,
    ConfigError,
    NodeConfig,
    ParamSpec,
    ParamValue,
    config_from_values,
    default_record_path,
)

__all__ = [
    "DESIGN_PARAMETERS",
    "GEOMETRY_PARAMETERS",
    "SPECS",
    "ConfigError",
    "NodeConfig",
    "ParamSpec",
    "config_from_values",
    "current_values",
    "declare_parameters",
    "default_record_path",
    "descriptor",
    "merged_values",
]


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
