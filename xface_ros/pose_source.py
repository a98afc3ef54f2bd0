"""A bundled pose source for demos: sweeps a few relative poses into ``relative_pose``.

Each pose is given in the paper's normalised units (x0 / D, theta0 in rad) and published as
the moving pivot frame in the base frame (see :mod:`xface_core.frames`), at a height of
``start_widths`` face widths, clear of contact. The default sweep mixes poses that seat with
poses that jam, miss the base or lie out of reach, and one input the node refuses.

Run alone (with the node started separately, same domain)::

    python -m xface_ros.pose_source --ros-args -p width_m:=0.05 -p rate_hz:=2.0
"""

from __future__ import annotations

from collections.abc import Sequence

import rclpy
from geometry_msgs.msg import PoseStamped
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor
from rclpy.context import Context
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data

from xface_core.frames import DockStart, start_to_relative_pose
from xface_ros import names
from xface_ros.conversions import planar_to_pose

__all__ = ["DEMO_SWEEP", "PoseSource", "main"]

#: (x0 / D, theta0 rad) of the default sweep, and what the default X-Face (H/D 0.25, r_p 1)
#: does from there.
DEMO_SWEEP: tuple[tuple[float, float], ...] = (
    (0.0, 0.0),  # centred and aligned: seats
    (0.3, 0.2),  # offset and turned: self-aligns and seats
    (0.9, 0.8),  # turned too far for the offset: jams (BAD_MATE)
    (-0.4, -0.3),  # the mirror side: seats
    (2.5, 0.0),  # beyond the mated pivot distance L = 2.25 D: OUT_OF_REACH
    (0.0, 1.2),  # steep angle: jams (BAD_MATE)
    (1.5, 0.3),  # passes beside the base: NO_CONTACT
    (0.0, 2.0),  # faces turned away from each other (|theta0| > pi/2): an invalid input
)


class PoseSource(Node):
    """Publishes the sweep in turn, one pose per timer tick, stamped with the node clock."""

    def __init__(
        self,
        sweep: Sequence[tuple[float, float]] = DEMO_SWEEP,
        *,
        context: Context | None = None,
        parameter_overrides: list[Parameter] | None = None,
    ) -> None:
        super().__init__(
            "xface_pose_source", context=context, parameter_overrides=parameter_overrides
        )
        positive = ParameterDescriptor(
            floating_point_range=[FloatingPointRange(from_value=1e-4, to_value=1e3, step=0.0)]
        )
        self.width_m = float(
            self.declare_parameter(
                "width_m", 0.05, ParameterDescriptor(description="Face width D (m).")
            ).value
        )
        self.start_widths = float(self.declare_parameter("start_widths", 3.0, positive).value)
        rate_hz = float(self.declare_parameter("rate_hz", 2.0, positive).value)
        self.base_frame = str(self.declare_parameter("base_frame", "xface_base").value)
        self._sweep = list(sweep)
        self._index = 0
        self._pub = self.create_publisher(PoseStamped, names.POSES, qos_profile_sensor_data)
        self._timer = self.create_timer(1.0 / rate_hz, self.publish_next)

    def pose_of(self, x0_widths: float, theta0: float) -> PoseStamped:
        """The message of one sweep entry, stamped now."""
        start = DockStart(
            x0=x0_widths * self.width_m, theta0=theta0, y_start=self.start_widths * self.width_m
        )
        msg = PoseStamped()
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.header.frame_id = self.base_frame
        msg.pose = planar_to_pose(start_to_relative_pose(start))
        return msg

    def publish_next(self) -> None:
        x0_widths, theta0 = self._sweep[self._index % len(self._sweep)]
        self._index += 1
        self._pub.publish(self.pose_of(x0_widths, theta0))

    @property
    def published(self) -> int:
        """Poses published so far."""
        return self._index


def main(args: list[str] | None = None) -> int:
    """Run the pose source until SIGINT or SIGTERM."""
    rclpy.init(args=args)
    node: PoseSource | None = None
    try:
        node = PoseSource()
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
