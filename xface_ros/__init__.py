"""xface_ros: the ROS 2 Jazzy adapter of xface (node ``xface_predictor``).

A thin layer over :mod:`xface_core`: messages <-> core types (:mod:`xface_ros.conversions`),
parameters (:mod:`xface_ros.params`), the node (:mod:`xface_ros.node`), a demo pose source
(:mod:`xface_ros.pose_source`) and the demo (:mod:`xface_ros.demo`). Importing this package
does not import rclpy; its submodules do. The interface is documented in docs/ros.md.
"""

__all__: list[str] = []
