"""The node's topics and services: their names and types, the contract docs/ros.md documents.

One source for the node, which makes them (:mod:`xface_ros.node`), and for the interface
snapshot (``tests/interfaces.json``, written by ``scripts/evidence/interface_snapshot.py``),
which the DDS check ``tests/ros/test_interface_names.py`` compares with what a planner sees.
Names are relative to the node's namespace, except ``/diagnostics``, which is absolute (ROS
convention). Types are given as ``package/msg/Name`` or ``package/srv/Name``. No ROS import:
the snapshot reads this module without ROS.
"""

from __future__ import annotations

# Published.
ACCEPTED = "prediction/accepted"
STATUS = "prediction/status"
PATH = "prediction/path"
SEATED_POSE = "prediction/seated_pose"
MARKERS = "prediction/markers"
RESULT = "prediction/result"
DIAGNOSTICS = "/diagnostics"
# Subscribed.
POSES = "relative_pose"
POSES_WITH_COVARIANCE = "relative_pose_with_covariance"
# Served.
PREDICT = "predict"
PREDICT_STATUS = "predict_status"
PREDICT_DOCK = "predict_dock"

#: Topic name to message type, for the topics the node publishes.
PUBLISHES: dict[str, str] = {
    ACCEPTED: "std_msgs/msg/Bool",
    STATUS: "diagnostic_msgs/msg/DiagnosticStatus",
    PATH: "nav_msgs/msg/Path",
    SEATED_POSE: "geometry_msgs/msg/PoseStamped",
    MARKERS: "visualization_msgs/msg/MarkerArray",
    RESULT: "xface_msgs/msg/DockPrediction",
    DIAGNOSTICS: "diagnostic_msgs/msg/DiagnosticArray",
}
#: Topic name to message type, for the topics the node subscribes to.
SUBSCRIBES: dict[str, str] = {
    POSES: "geometry_msgs/msg/PoseStamped",
    POSES_WITH_COVARIANCE: "geometry_msgs/msg/PoseWithCovarianceStamped",
}
#: Service name to service type, for the services the node serves.
SERVES: dict[str, str] = {
    PREDICT: "nav_msgs/srv/GetPlan",
    PREDICT_STATUS: "diagnostic_msgs/srv/SelfTest",
    PREDICT_DOCK: "xface_msgs/srv/PredictDock",
}
#: The names that exist only where the typed interface ``xface_msgs`` is built
#: (``xface_ros.conversions.typed_interface_problem`` is None).
TYPED = frozenset({RESULT, PREDICT_DOCK})
