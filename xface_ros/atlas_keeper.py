"""The node's acceptance atlas: built in the background for the current design and physics.

Margins from an atlas cost a few exact simulations instead of hundreds
(:mod:`xface_core.atlas`, docs/atlas.md). Building one takes seconds, so the node builds it on
a thread of its own at start and again after a design or physics parameter changes; until it
is ready (or when a build failed) predictions search their margins exactly, as without it,
and ``/diagnostics`` says which (``atlas``: ``building``, ``ready``, ``failed``, ``off``).
Imports no rclpy.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Hashable
from typing import TYPE_CHECKING

from xface_core.atlas import AcceptanceAtlas, build_atlas, cache_path
from xface_core.geometry import FaceDesign
from xface_core.physics import Physics
from xface_ros.config import NodeConfig
from xface_ros.threadname import name_os_thread

if TYPE_CHECKING:
    from xface_ros.worker import Logger

__all__ = ["AtlasKeeper"]

Builder = Callable[[FaceDesign, Physics, str], AcceptanceAtlas]


def _key(config: NodeConfig) -> Hashable:
    """What an atlas depends on: the geometry, its width and the physics."""
    return (config.design.cache_key, config.design.width, config.physics)


class AtlasKeeper:
    """The atlas of the newest design and physics asked for, once built.

    :meth:`get` is cheap and never blocks: it returns the ready atlas for ``config``, or None
    and (for a design not asked for before) starts a build in the background. Only the newest
    request is kept; a build that finishes for an older design is dropped.
    """

    def __init__(self, logger: Logger, *, build: Builder | None = None) -> None:
        self._logger = logger
        self._build = build or self._build_or_load
        self._lock = threading.Lock()
        self._wanted: Hashable | None = None
        self._atlas: AcceptanceAtlas | None = None
        self._state = "off"
        self._threads: list[threading.Thread] = []
        # Where the ready atlas is cached ("" = nowhere) and how many grid-line flips it
        # held when it was last written or read there.
        self._cache_dir = ""
        self._flips_on_disk = 0

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
            self._wanted, self._atlas, self._state = key, None, "building"
        thread = threading.Thread(
            target=self._run, args=(key, config), name="xface_atlas", daemon=True
        )
        # Finished builds are forgotten: a node whose design changes often keeps no list.
        self._threads = [t for t in self._threads if t.is_alive()] + [thread]
        thread.start()
        return None

    def _build_or_load(
        self, design: FaceDesign, physics: Physics, cache_dir: str
    ) -> AcceptanceAtlas:
        """Build the atlas, or load it from ``cache_dir`` (empty: no cache). A cache that
        cannot be written costs the next start its build, not this one its atlas."""
        if not cache_dir:
            return build_atlas(design, physics=physics)
        try:
            return build_atlas(design, physics=physics, cache_dir=cache_dir)
        except OSError as exc:
            self._logger.warning(f"atlas cache {cache_dir!r} not usable, atlas not kept: {exc}")
            return build_atlas(design, physics=physics)

    def join(self, timeout_s: float = 60.0) -> None:
        """Wait for the builds started so far (tests, shutdown)."""
        for thread in self._threads:
            thread.join(timeout=timeout_s)

    def _run(self, key: Hashable, config: NodeConfig) -> None:
        name_os_thread(threading.current_thread().name)
        try:
            atlas = self._build(config.design, config.physics, config.atlas_cache_dir)
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
            self._cache_dir, self._flips_on_disk = config.atlas_cache_dir, len(atlas.flips)
        self._logger.info("acceptance atlas ready: margins from the atlas")

    def persist(self) -> tuple[str, bool] | None:
        """Write the ready atlas to its cache again if it found grid-line flips since it was
        built or loaded (they make a restart's first margins near them cheap): a sentence
        saying what happened and whether the write failed, or None when there was nothing to
        write. Never raises: the node calls it while shutting down."""
        with self._lock:
            atlas, cache_dir, on_disk = self._atlas, self._cache_dir, self._flips_on_disk
        if atlas is None or not cache_dir:
            return None
        flips = len(atlas.flips)
        if flips <= on_disk:
            return None
        path = cache_path(cache_dir, atlas.key)
        try:
            atlas.save(path)
        except (OSError, ValueError) as exc:
            return f"atlas cache {cache_dir!r}: the {flips} grid-line flips not kept: {exc}", True
        with self._lock:
            if self._atlas is atlas:
                self._flips_on_disk = flips
        return f"acceptance atlas saved with {flips} grid-line flips: {path}", False
