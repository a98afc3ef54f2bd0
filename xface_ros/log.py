"""What the node's helpers need of a logger: the :class:`Logger` protocol.

The worker, the atlas keeper and the recorder log through the node's logger (rclpy's, which
has these methods) without importing rclpy, and tests pass a fake. Imports no rclpy.
"""

from __future__ import annotations

from typing import Any, Protocol

__all__ = ["Logger"]


class Logger(Protocol):
    """What the worker, the atlas keeper and the recorder need of a logger (rclpy's node
    logger has it); keyword arguments such as ``throttle_duration_sec`` go through."""

    def info(self, message: str, **kwargs: Any) -> Any: ...
    def warning(self, message: str, **kwargs: Any) -> Any: ...
    def error(self, message: str, **kwargs: Any) -> Any: ...
