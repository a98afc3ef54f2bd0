"""``python -m xface_ros --ros-args ...`` runs the ``xface_predictor`` node."""

from xface_ros.node import main

raise SystemExit(main())
