"""What ``/diagnostics`` counts: thread-safe counters of the node's poses and verdicts.

The worker owns one :class:`PredictorStats` and counts into it (poses received, verdicts,
the warm-up and its progress, service calls, recording errors); the node takes a
:class:`StatsSnapshot` for each ``/diagnostics`` message, which :mod:`xface_ros.diagnostics`
formats. Imports no rclpy. Units: stamps and clocks in nanoseconds, durations in seconds
unless a name ends in ``_ms``.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

from xface_core.codes import Outcome
from xface_ros.decision import Rejected, Verdict

__all__ = ["PredictorStats", "StatsCounts", "StatsSnapshot", "StatsWindow"]


@dataclass
class StatsWindow:
    """Counters and samples since the last diagnostics message."""

    received: int = 0
    predicted: int = 0
    latency_ms: list[float] = field(default_factory=list)
    """Input stamp to publication (ms), one per prediction."""
    compute_ms: list[float] = field(default_factory=list)
    """Simulation wall time (ms), one per prediction."""


@dataclass
class StatsCounts:
    """Running totals and the last event of each kind (the counts the slot does not keep)."""

    warming_up: bool = True
    """True until the simulator is loaded (the first simulation compiles or loads it)."""
    engine: str = ""
    """Where the warm-up gets the compiled simulator: ``precompiled`` (shipped with the
    install), ``cached`` (numba's cache) or ``compiles`` (compiled now); "" before it begins."""
    warm_up_done: int = 0
    """Compiled entry points the warm-up has loaded (or compiled) so far."""
    warm_up_total: int = 0
    """Compiled entry points the warm-up loads; 0 until the engine has said how many."""
    warm_up_s: float = 0.0
    """Seconds since the warm-up began (monotonic clock, not the node's, which may be sim time
    and stand still); once it is over, how long it took."""
    predicted_total: int = 0
    input_errors_total: int = 0
    dds_lost_reported_total: int = 0
    """Losses the middleware reported (message-lost event); Fast DDS reports none for a best-effort
    reader queue that overflows, so this is not a count of the poses that never arrived."""
    service_calls_total: int = 0
    recording_errors_total: int = 0
    last_outcome: str = "none"
    last_accepted: bool | None = None
    """None when the last streamed pose was rejected, or before the first."""
    last_input_error: str = ""
    last_latency_ms: float = math.nan
    last_stamp_ns: int | None = None
    """Header stamp (ns) of the last pose received."""


@dataclass(frozen=True)
class StatsSnapshot:
    """Everything ``/diagnostics`` reports, taken at one instant (``now_ns``)."""

    now_ns: int
    window: StatsWindow
    window_s: float
    """Length of the window (s), > 0."""
    received_total: int
    dropped_total: int
    counts: StatsCounts

    @property
    def pose_age_s(self) -> float:
        """Clock minus the last received pose's stamp (s); NaN before the first pose."""
        if self.counts.last_stamp_ns is None:
            return math.nan
        return (self.now_ns - self.counts.last_stamp_ns) * 1e-9


class PredictorStats:
    """Thread-safe counters for ``/diagnostics``: which events count, and how."""

    #: Bound on the samples kept per diagnostics window (memory stays flat at any rate).
    MAX_SAMPLES = 5000

    def __init__(self, *, start_ns: int, monotonic_s: Callable[[], float] = time.monotonic) -> None:
        """``monotonic_s``: the clock of the warm-up's duration (a test passes its own)."""
        self._lock = threading.Lock()
        self._window = StatsWindow()
        self._window_start_ns = start_ns
        self._counts = StatsCounts()
        self._monotonic_s = monotonic_s
        self._warm_up_started_s: float | None = None

    def count_received(self, stamp_ns: int) -> None:
        """A pose arrived (``stamp_ns``: its header stamp)."""
        with self._lock:
            self._window.received += 1
            self._counts.last_stamp_ns = stamp_ns

    def count_verdict(self, verdict: Verdict, *, latency_ms: float) -> None:
        """A streamed pose was answered (``latency_ms``: its stamp to publication)."""
        with self._lock:
            counts = self._counts
            if isinstance(verdict, Rejected):
                counts.input_errors_total += 1
                counts.last_outcome = Outcome.INVALID_INPUT.name
                counts.last_accepted = None
                counts.last_input_error = verdict.code
                return
            counts.predicted_total += 1
            counts.last_outcome = verdict.prediction.outcome.name
            counts.last_accepted = verdict.accepted
            counts.last_input_error = ""
            counts.last_latency_ms = latency_ms
            self._window.predicted += 1
            if len(self._window.latency_ms) < self.MAX_SAMPLES:
                self._window.latency_ms.append(latency_ms)
                self._window.compute_ms.append(verdict.compute_s * 1e3)

    def count_service_call(self) -> None:
        with self._lock:
            self._counts.service_calls_total += 1

    def count_recording_error(self) -> None:
        with self._lock:
            self._counts.recording_errors_total += 1

    def set_dds_lost_reported_total(self, total: int) -> None:
        """The middleware's running count of the lost messages it reports."""
        with self._lock:
            self._counts.dds_lost_reported_total = int(total)

    def start_warm_up(self, engine: str) -> None:
        """The warm-up begins; ``engine``: where the compiled simulator comes from
        (:attr:`StatsCounts.engine`)."""
        with self._lock:
            self._warm_up_started_s = self._monotonic_s()
            self._counts.engine = engine

    def set_warm_up_progress(self, done: int, total: int) -> None:
        """``done`` of the ``total`` compiled entry points are loaded (or compiled)."""
        with self._lock:
            self._counts.warm_up_done = int(done)
            self._counts.warm_up_total = int(total)

    def set_warming_up(self, warming_up: bool) -> None:
        with self._lock:
            if self._counts.warming_up and not warming_up:  # over: keep how long it took
                self._counts.warm_up_s = self._warm_up_elapsed_s()
            self._counts.warming_up = warming_up

    def _warm_up_elapsed_s(self) -> float:
        """Seconds since :meth:`start_warm_up` (0 before it); call with the lock held."""
        started = self._warm_up_started_s
        return 0.0 if started is None else max(self._monotonic_s() - started, 0.0)

    @property
    def warming_up(self) -> bool:
        """True until the simulator is loaded."""
        with self._lock:
            return self._counts.warming_up

    def take_snapshot(
        self, now_ns: int, *, received_total: int, dropped_total: int
    ) -> StatsSnapshot:
        """The counts and the window since the last call (at ``now_ns``), which starts a new
        window. ``received_total`` and ``dropped_total`` come from the pose slot."""
        with self._lock:
            window, self._window = self._window, StatsWindow()
            start_ns, self._window_start_ns = self._window_start_ns, now_ns
            counts = replace(self._counts)
            if counts.warming_up:
                counts.warm_up_s = self._warm_up_elapsed_s()
        return StatsSnapshot(
            now_ns=now_ns,
            window=window,
            window_s=max((now_ns - start_ns) * 1e-9, 1e-9),
            received_total=received_total,
            dropped_total=dropped_total,
            counts=counts,
        )
