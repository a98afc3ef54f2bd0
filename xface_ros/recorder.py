"""The node's rerun recording of streamed predictions (``record: true``).

A thin owner of one ``rerun.RecordingStream`` made by :mod:`xface_core.viz.recording`, which
is imported only when a recording is asked for (rerun is heavy and optional). Imports no
rclpy: the node opens it, the worker records into it, the node finishes it at shutdown.
"""

from __future__ import annotations

from typing import Any

from xface_core.result import Prediction
from xface_ros.config import NodeConfig, default_record_path
from xface_ros.log import Logger

__all__ = ["Recorder"]


class Recorder:
    """An open recording: ``path`` is the ``.rrd`` file, ``url`` a live viewer or ``""``."""

    def __init__(self, stream: Any, *, path: str, url: str) -> None:
        self._stream = stream
        self.path = path
        self.url = url

    @classmethod
    def open(cls, config: NodeConfig, logger: Logger) -> Recorder | None:
        """The recording ``config`` asks for; None when ``record`` is off or the recording
        module is missing (logged as an error: the node then predicts without recording)."""
        if not config.record:
            return None
        try:
            from xface_core.viz import recording
        except ImportError as exc:
            logger.error(f"record is true but xface_core.viz.recording is missing: {exc}")
            return None
        path = config.record_path or default_record_path()
        stream = recording.new_recording(
            application_id="xface",
            path=path,
            url=config.record_url or None,
            # Opens on the node's timeline: the verdict series over the poses' stamps.
            blueprint=recording.default_blueprint(active="node"),
        )
        logger.info(
            f"recording predictions to {path}"
            + (f" and {config.record_url}" if config.record_url else "")
        )
        return cls(stream, path=path, url=config.record_url)

    def record(self, prediction: Prediction, *, stamp_ns: int, accepted: bool) -> None:
        """Log one prediction on the ``ros2_timestamp`` timeline at ``stamp_ns`` (the input's
        header stamp, ns since the epoch): its path, and the verdict series (outcome code,
        ``accepted`` as the node decided it, the margins, the input pose). Raises what rerun
        raises."""
        from xface_core.viz import recording

        recording.log_prediction(self._stream, prediction, ros_stamp_ns=stamp_ns)
        recording.log_verdict(self._stream, prediction, accepted=accepted, ros_stamp_ns=stamp_ns)

    def finish(self, *, timeout_s: float = 10.0) -> None:
        """Flush (waiting up to ``timeout_s``) and disconnect, which writes the file's footer."""
        self._stream.flush(timeout_sec=timeout_s)
        self._stream.disconnect()
