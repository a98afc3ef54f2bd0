"""The node's acceptance atlas: built in the background for the current design and physics.

Margins from an atlas cost a few exact simulations instead of hundreds
(:mod:`xface_core.atlas.build`, docs/atlas.md). Building one takes seconds, so the node builds it on
a thread of its own at start and again after a design or physics parameter changes; until it
is ready (or when a build failed) predictions search their margins exactly, as without it,
and ``/diagnostics`` says which (``atlas``: ``building``, ``ready``, ``failed``, ``off``).
Imports no rclpy.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Hashable
from functools import partial

from xface_core.atlas.build import AcceptanceAtlas, build_atlas
from xface_core.errors import Cancelled
from xface_core.geometry import FaceDesign
from xface_core.physics import Physics
from xface_ros.config import NodeConfig
from xface_ros.log import Logger
from xface_ros.threadname import name_os_thread

__all__ = ["AtlasKeeper"]

#: Builds an atlas: design, physics, cache directory ("" for none), and a callback that says
#: when nobody wants the atlas any more (the builder stops with ``Cancelled`` then).
Builder = Callable[[FaceDesign, Physics, str, Callable[[], bool]], AcceptanceAtlas]


def _key(config: NodeConfig) -> Hashable:
    """What an atlas depends on: the geometry, its width and the physics."""
    return (config.design.cache_key, config.design.width, config.physics)


class AtlasKeeper:
    """The atlas of the newest design and physics asked for, once built.

    :meth:`get` is cheap and never blocks: it returns the ready atlas for ``config``, or None
    and (for a design not asked for before) starts a build in the background. Only the newest
    request is kept: a build for an older design stops at its next batch of simulations, and
    :meth:`stop` stops them all.
    """

    def __init__(self, logger: Logger, *, build: Builder | None = None) -> None:
        self._logger = logger
        self._build = build or self._build_or_load
        self._lock = threading.Lock()
        self._wanted: Hashable | None = None
        self._atlas: AcceptanceAtlas | None = None
        self._state = "off"
        self._stopping = False
        self._threads: list[threading.Thread] = []

    @property
    def state(self) -> str:
        """``off`` (never asked), ``building``, ``ready`` or ``failed``."""
        with self._lock:
            return self._state

    def get(self, config: NodeConfig) -> AcceptanceAtlas | None:
        """The ready atlas of ``config``'s design and physics, else None (starting a build)."""
        key = _key(config)
        with self._lock:
            if key == self._wanted:
                return self._atlas
            if self._stopping:
                return None
            self._wanted, self._atlas, self._state = key, None, "building"
        thread = threading.Thread(
            target=self._run, args=(key, config), name="xface_atlas", daemon=True
        )
        # Finished builds are forgotten: a node whose design changes often keeps no list.
        self._threads = [t for t in self._threads if t.is_alive()] + [thread]
        thread.start()
        return None

    def _build_or_load(
        self, design: FaceDesign, physics: Physics, cache_dir: str, cancel: Callable[[], bool]
    ) -> AcceptanceAtlas:
        """Build the atlas with every grid-line flip bisected (a planner's first question
        near a boundary then takes eight confirmations, not a search) and its boundary
        cells' chords checked (the seat probabilities draw boundaries from them), or load it from
        ``cache_dir`` (empty: no cache). A bad cache file is rebuilt and replaced, and a cache
        that cannot be written costs the next start its build, not this one its atlas: each
        is one warning in the log naming the file and why, never an exception."""
        build = partial(build_atlas, design, physics=physics, every_flip=True, cancel=cancel)
        if not cache_dir:
            atlas = build()
        else:
            atlas = build(
                cache_dir=cache_dir,
                on_cache_problem=lambda why: self._logger.warning(f"atlas cache not usable: {why}"),
            )
        # The seat probabilities read the boundary cells' checked chords: checked here, in
        # the background, not by the first pose with a covariance (0.1-0.7 s).
        atlas.checked_chords()
        return atlas

    def join(self, timeout_s: float = 60.0) -> None:
        """Wait for the builds started so far (tests, :meth:`stop`)."""
        for thread in self._threads:
            thread.join(timeout=timeout_s)

    def stop(self, timeout_s: float = 60.0) -> None:
        """Stop every build at its next batch of simulations, start no more, and wait for
        them (shutdown: a build left running on its daemon thread would run compiled code
        and log through the node while rclpy and the interpreter are torn down)."""
        with self._lock:
            self._stopping = True
        self.join(timeout_s)

    def _cancelled(self, key: Hashable) -> bool:
        """Nobody wants the atlas of ``key`` any more: a newer design, or stopping."""
        with self._lock:
            return self._stopping or key != self._wanted

    def _run(self, key: Hashable, config: NodeConfig) -> None:
        name_os_thread(threading.current_thread().name)
        try:
            atlas = self._build(
                config.design, config.physics, config.atlas_cache_dir,
                lambda: self._cancelled(key),
            )  # fmt: skip
        except Cancelled:
            return  # a newer design is being built, or the node stops
        except Exception as exc:  # margins fall back to the exact search: never fatal
            with self._lock:
                if key == self._wanted:
                    self._state = "failed"
            self._logger.error(f"acceptance atlas failed, margins searched exactly: {exc!r}")
            return
        with self._lock:
            if key != self._wanted:
                return  # the design changed while this one was being built
            self._atlas, self._state = atlas, "ready"
        self._logger.info("acceptance atlas ready: margins from the atlas")
