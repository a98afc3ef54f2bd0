"""The prediction worker: one thread that simulates the newest streamed pose.

The subscription hands each pose to :meth:`PredictionWorker.submit`, which only stores it in a
one-slot mailbox (:class:`~xface_ros.latest.LatestSlot`: the newest pose wins, an overwritten
one is counted as dropped). The worker thread first warms the simulator up: it loads every
compiled entry point (:func:`xface_core.runner.warm_up_engine`: seconds from the install's
precompiled engine or numba's cache, minutes of CPU where it compiles), counting its progress
in the stats for ``/diagnostics``, then predicts once through each entry a pose can take. Then
it takes the newest pose whenever it is free, asks :mod:`xface_ros.decision` for the verdict
and hands it to the node's ``publish`` callback. It owns the :class:`PredictorStats`.

Imports no rclpy: the node passes in its clock, its logger and its publishing as callables,
so the worker is tested without DDS (tests/ros/test_worker.py).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from xface_core.atlas.build import AcceptanceAtlas
from xface_core.predict import predict
from xface_core.result import Prediction
from xface_core.runner import engine_state, warm_up_engine
from xface_ros.atlas_keeper import AtlasKeeper
from xface_ros.config import NodeConfig
from xface_ros.decision import PoseInput, Rejected, Verdict, evaluate_streamed
from xface_ros.latest import LatestSlot, Received
from xface_ros.log import Logger
from xface_ros.recorder import Recorder
from xface_ros.stats import PredictorStats, StatsSnapshot
from xface_ros.threadname import name_os_thread

__all__ = ["COMPILING_LOG", "LOG_THROTTLE_S", "PredictionWorker", "warm_up_simulator"]

#: Seconds between repeats of the same throttled log line.
LOG_THROTTLE_S = 5.0

#: Logged before a warm-up that compiles the simulator (numba's cache holds none of it).
COMPILING_LOG = (
    "compiling the simulator first (the install's precompiled one does not serve this "
    "process: 1-2 minutes of CPU, then numba's cache keeps it); poses wait, /diagnostics says "
    "warming up"
)

#: How long the worker waits for a pose before it checks whether to stop (s).
_POLL_S = 0.2

#: Loads (or compiles) every compiled entry point, calling ``progress(done, total)`` after each.
EngineLoader = Callable[[Callable[[int, int], None] | None], None]


class _WarmUpStopped(Exception):
    """Raised from the warm-up's progress callback once the worker is told to stop: a
    warm-up that compiles takes minutes, and a node shut down meanwhile should not wait for
    all of it (it stops after the entry point in progress)."""


def warm_up_simulator(config: NodeConfig) -> None:
    """Predictions through every compiled entry a pose can take, so the first real pose does
    not pay for loading (or, after an install or a change, compiling) one.

    With its path and ``margins=True``: the single-pose entry with a path and the batch
    kernel of the margin search, the atlas and ``min_margin``. Without its path: the entry a
    streamed pose takes when nobody subscribes to paths. Left out once, its compilation
    stalled the first streamed poses of a fresh install for 5-7 s (scripts/bench/ros_stress.py).
    """
    for with_path in (True, False):
        predict(
            config.design,
            0.0,
            0.0,
            physics=config.physics,
            path=with_path,
            margins=with_path,
        )


class PredictionWorker:
    """Simulates streamed poses on its own thread, newest first; owns the pose slot and stats.

    Parameters
    ----------
    config : callable
        The node's current :class:`NodeConfig`; read once per pose.
    now_ns : callable
        The node's clock (ns).
    wants_path : callable
        Whether anyone needs the alignment path now (path or markers subscribers, a
        recording); paths are not computed otherwise.
    publish : callable
        Publishes a verdict with the config it was computed with; called on the worker thread.
    logger : Logger
    recorder : Recorder, optional
        Gets every streamed prediction; a failure is counted and logged, never fatal.
    shutting_down : callable, optional
        True once the node is going away: a failed publish then ends the worker quietly.
    warm_up : callable, optional
        The warm-up predictions, after the engine is loaded; default :func:`warm_up_simulator`.
    load_engine : callable, optional
        Loads (or compiles) every compiled entry point with a progress callback; default
        :func:`xface_core.runner.warm_up_engine`.
    atlas : AtlasKeeper, optional
        The acceptance atlas of the current design (built in the background after the
        warm-up); its margins are used once it is ready. None: margins always exact.
    """

    def __init__(
        self,
        *,
        config: Callable[[], NodeConfig],
        now_ns: Callable[[], int],
        wants_path: Callable[[], bool],
        publish: Callable[[Verdict, NodeConfig], None],
        logger: Logger,
        recorder: Recorder | None = None,
        shutting_down: Callable[[], bool] = lambda: False,
        warm_up: Callable[[NodeConfig], None] | None = None,
        load_engine: EngineLoader | None = None,
        atlas: AtlasKeeper | None = None,
    ) -> None:
        self._config = config
        self.atlas = atlas
        self._now_ns = now_ns
        self._wants_path = wants_path
        self._publish = publish
        self._logger = logger
        self._recorder = recorder
        self._shutting_down = shutting_down
        self._warm_up_simulator = warm_up or warm_up_simulator
        self._load_engine = load_engine or warm_up_engine
        self.slot: LatestSlot[PoseInput] = LatestSlot()
        self.stats = PredictorStats(start_ns=now_ns())
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="xface_predictor", daemon=True)

    # --- the node's side --------------------------------------------------------------------

    def start(self) -> None:
        """Start the thread: it warms up first, then predicts."""
        self._thread.start()

    def submit(self, pose: PoseInput, *, receive_ns: int) -> None:
        """Store a received pose (``receive_ns``: the node clock at arrival) for the worker."""
        self.slot.put(pose, receive_ns=receive_ns)
        self.stats.count_received(pose.stamp_ns)

    @property
    def latest_pose(self) -> PoseInput | None:
        """The newest pose received, predicted or not (the service's "use the latest")."""
        latest = self.slot.latest
        return None if latest is None else latest.message

    @property
    def warming_up(self) -> bool:
        """True until the warm-up simulation has finished (or failed)."""
        return self.stats.warming_up

    @property
    def atlas_state(self) -> str:
        """The atlas's state for ``/diagnostics``: off, building, ready or failed."""
        return "off" if self.atlas is None else self.atlas.state

    def current_atlas(self, config: NodeConfig) -> AcceptanceAtlas | None:
        """The ready atlas of ``config``, else None (a design or physics change starts its
        build; until then margins are exact and seat probabilities not computed)."""
        if self.atlas is None or self.warming_up:
            return None
        return self.atlas.get(config)

    def take_stats(self, now_ns: int) -> StatsSnapshot:
        """The diagnostics snapshot at ``now_ns``; starts a new window."""
        return self.stats.take_snapshot(
            now_ns, received_total=self.slot.received, dropped_total=self.slot.dropped
        )

    def stop(self, timeout_s: float = 30.0) -> None:
        """Stop the thread and an atlas build still running, and wait up to ``timeout_s``
        for each (idempotent)."""
        self._stop.set()
        self.slot.close()
        if self._thread.is_alive():
            self._thread.join(timeout=timeout_s)
        if self.atlas is not None:
            # A build starts after the warm-up. Left running on its daemon thread, it runs
            # compiled code and logs through the node while rclpy and the interpreter are
            # torn down. A managed node shut down right after its configure
            # (tests/ros/test_node_managed.py, whose node never saw its build end) died with
            # SIGSEGV on SIGINT once in CI; not reproduced in 24 runs since.
            self.atlas.stop(timeout_s)

    # --- the worker thread ------------------------------------------------------------------

    def _run(self) -> None:
        name_os_thread(self._thread.name)
        self._warm_up()
        while not self._stop.is_set():
            item = self.slot.take(timeout_s=_POLL_S)
            if item is None:
                continue
            try:
                self.process(item)
            except Exception as exc:  # a bug in one prediction must not end the stream
                if self._shutting_down():
                    return  # the publishers are gone: nothing to report to
                self._report_failure(item.message, exc)

    def _warm_up(self) -> None:
        """Load the engine (counting its progress for ``/diagnostics``), predict once through
        each entry, then start the atlas; a failure is logged and ends the warm-up all the
        same (each pose reports it again)."""
        t0 = time.perf_counter()
        state = engine_state()
        # Why the install's precompiled engine does not serve (an install that skipped it, a
        # numba upgrade, edited engine sources): the reason a first start compiles.
        why = "" if state.ready else f"; {state.why_not_precompiled or 'not precompiled'}"
        self._logger.info(f"simulator: {state.describe()}{why}")
        self.stats.start_warm_up(state.source)
        if not state.ready:  # say why the first poses wait
            self._logger.info(COMPILING_LOG)
        try:
            self._load_engine(self._engine_progress(compiles=not state.ready, t0=t0))
            self._warm_up_simulator(self._config())
        except _WarmUpStopped:
            return  # the node is going away: no atlas to build
        except Exception as exc:  # reported again, per pose, by the predictions
            self._logger.warning(f"warm-up prediction failed: {exc!r}")
        else:
            elapsed_s = time.perf_counter() - t0
            if elapsed_s > 1.0:
                self._logger.info(f"simulator loaded in {elapsed_s:.1f} s")
        finally:
            self.stats.set_warming_up(False)
        if self.atlas is not None:
            self.atlas.get(self._config())  # start building it (on a thread of its own)

    def _engine_progress(self, *, compiles: bool, t0: float) -> Callable[[int, int], None]:
        """The engine's progress callback: counts for ``/diagnostics``, a log line per entry
        when it compiles (minutes, so the log shows it moving), and the way out of a warm-up
        the node no longer wants (:class:`_WarmUpStopped`)."""

        def progress(done: int, total: int) -> None:
            self.stats.set_warm_up_progress(done, total)
            if compiles:
                elapsed_s = time.perf_counter() - t0
                self._logger.info(f"compiling the simulator: {done}/{total} ({elapsed_s:.0f} s)")
            if self._stop.is_set():
                raise _WarmUpStopped

        return progress

    def process(self, item: Received[PoseInput]) -> Verdict:
        """Decide one streamed pose, publish, count and record it; the verdict."""
        config = self._config()
        verdict = evaluate_streamed(
            item.message,
            config,
            receive_ns=item.receive_ns,
            path=self._recorder is not None or self._wants_path(),
            atlas=self.current_atlas(config),
        )
        self._deliver(verdict, config)
        return verdict

    def _deliver(self, verdict: Verdict, config: NodeConfig) -> None:
        try:
            self._publish(verdict, config)
            published_ns = self._now_ns()
        finally:
            # Recorded even when publishing fails part-way: a signal can take the context down
            # between the status and the next output, and a client may already hold that status
            # (the recording is finished after this worker stops, so nothing decided is lost).
            if not isinstance(verdict, Rejected) and self._recorder is not None:
                self._record(self._recorder, verdict.prediction, verdict.stamp_ns, verdict.accepted)
        self.stats.count_verdict(verdict, latency_ms=(published_ns - verdict.stamp_ns) * 1e-6)
        if isinstance(verdict, Rejected):
            self._logger.error(
                f"pose rejected: {verdict.code}: {verdict.detail}",
                throttle_duration_sec=LOG_THROTTLE_S,
            )

    def _record(
        self, recorder: Recorder, prediction: Prediction, stamp_ns: int, accepted: bool
    ) -> None:
        try:
            recorder.record(prediction, stamp_ns=stamp_ns, accepted=accepted)
        except Exception as exc:  # a recording problem must never stop the predictions
            self.stats.count_recording_error()
            self._logger.error(f"recording failed: {exc!r}", throttle_duration_sec=LOG_THROTTLE_S)

    def _report_failure(self, pose: PoseInput, exc: Exception) -> None:
        """Publish an ``internal_error`` for a pose whose processing raised."""
        try:
            self._deliver(Rejected(pose.stamp_ns, "internal_error", repr(exc)), self._config())
        except Exception:
            if not self._shutting_down():  # not a shutdown race: a real failure, keep it
                raise
