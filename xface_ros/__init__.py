"""xface_ros: the ROS 2 Jazzy adapter of xface (node ``xface_predictor``).

A thin layer over :mod:`xface_core`. The node (:mod:`xface_ros.node`) is wiring only; the
rules live in :mod:`xface_ros.decision` (ROS-free: input checks, verdicts, stats) over the
ROS-free configuration (:mod:`xface_ros.config`); the prediction thread is
:mod:`xface_ros.worker` (with :mod:`xface_ros.recorder` for rerun recordings); messages are
built by :mod:`xface_ros.conversions` and :mod:`xface_ros.diagnostics`; ROS parameters are
declared by :mod:`xface_ros.params`. A demo pose source (:mod:`xface_ros.pose_source`) and
the demo (:mod:`xface_ros.demo`) come with it. Importing this package does not import rclpy;
some submodules do. The interface is documented in docs/ros.md.
"""

__all__: list[str] = []
