"""The node's acceptance atlas (xface_ros.atlas_keeper), without DDS: built in the background,
used once ready, dropped when the design changes, never fatal."""

from __future__ import annotations

import math
import sys
import threading
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

import xface_core as xf
from xface_core.errors import Cancelled
from xface_ros.atlas_keeper import AtlasKeeper
from xface_ros.config import SPECS, ConfigError, NodeConfig, config_from_values
from xface_ros.decision import SEAT_BOUNDARY, PoseInput, evaluate_streamed

NOW_NS = 1_700_000_000_000_000_000


class Log:
    def __init__(self) -> None:
        self.lines: list[str] = []

    def info(self, message: str, **_: Any) -> None:
        self.lines.append(message)

    warning = error = info


@pytest.fixture(scope="module")
def config() -> NodeConfig:
    return config_from_values({spec.name: spec.default for spec in SPECS})


def _coarse(
    design: xf.FaceDesign, physics: xf.Physics, cache_dir: str = "", cancel: Any = None
) -> xf.AcceptanceAtlas:
    return xf.build_atlas(design, physics=physics, lateral_step=1 / 16, angle_step=0.05)


def _ready(config: NodeConfig) -> tuple[AtlasKeeper, xf.AcceptanceAtlas]:
    """A keeper (a node's, started afresh) and its atlas for ``config``, once ready."""
    keeper = AtlasKeeper(Log())
    keeper.get(config)
    keeper.join(timeout_s=600.0)
    atlas = keeper.get(config)
    assert atlas is not None
    return keeper, atlas


def test_the_atlas_is_built_in_the_background_and_then_used(config: NodeConfig) -> None:
    keeper = AtlasKeeper(Log(), build=_coarse)
    assert keeper.state == "off"
    assert keeper.get(config) is None  # starts the build, answers at once
    keeper.join()
    assert keeper.state == "ready"
    atlas = keeper.get(config)
    assert atlas is not None
    assert atlas.design.cache_key == config.design.cache_key


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="Linux thread names")
def test_the_build_runs_on_a_thread_named_for_the_os(config: NodeConfig) -> None:
    names: list[str] = []

    def build(
        design: xf.FaceDesign, physics: xf.Physics, cache_dir: str, cancel: Any
    ) -> xf.AcceptanceAtlas:
        comm = Path(f"/proc/self/task/{threading.get_native_id()}/comm")
        names.append(comm.read_text().strip())
        return _coarse(design, physics)

    keeper = AtlasKeeper(Log(), build=build)
    keeper.get(config)
    keeper.join()
    assert names == ["xface_atlas"]


def test_a_design_change_starts_a_new_build_and_drops_the_old_atlas(config: NodeConfig) -> None:
    keeper = AtlasKeeper(Log(), build=_coarse)
    keeper.get(config)
    keeper.join()
    other = replace(config, design=xf.make_face("V", 0.5, 1.0, width=config.width_m))
    assert keeper.get(other) is None
    keeper.join()
    atlas = keeper.get(other)
    assert atlas is not None
    assert atlas.design.kind == "V"


def test_a_build_finished_for_an_older_design_is_not_used(config: NodeConfig) -> None:
    release = threading.Event()

    def slow(
        design: xf.FaceDesign, physics: xf.Physics, cache_dir: str, cancel: Any
    ) -> xf.AcceptanceAtlas:
        release.wait(30.0)
        return _coarse(design, physics)

    keeper = AtlasKeeper(Log(), build=slow)
    keeper.get(config)
    other = replace(config, design=xf.make_face("V", 0.5, 1.0, width=config.width_m))
    keeper.get(other)  # the newer request wins
    release.set()
    keeper.join()
    atlas = keeper.get(other)
    assert atlas is not None
    assert atlas.design.kind == "V"


def test_a_failed_build_is_logged_and_margins_stay_exact(config: NodeConfig) -> None:
    def broken(
        design: xf.FaceDesign, physics: xf.Physics, cache_dir: str, cancel: Any
    ) -> xf.AcceptanceAtlas:
        raise MemoryError("no room")

    log = Log()
    keeper = AtlasKeeper(log, build=broken)
    keeper.get(config)
    keeper.join()
    assert keeper.state == "failed"
    assert keeper.get(config) is None
    assert any("acceptance atlas failed" in line for line in log.lines)


def test_streamed_margins_from_the_atlas_equal_the_exact_ones(config: NodeConfig) -> None:
    keeper = AtlasKeeper(Log(), build=_coarse)
    keeper.get(config)
    keeper.join()
    # 3 D above the base: clear of it at every angle, as a robot's stream starts.
    pose = PoseInput("xface_base", NOW_NS, (0.3 * config.width_m, 3.0 * config.width_m, 0.0),
                     (0.0, 0.0, 0.9950041652780258, 0.09983341664682815))  # fmt: skip
    fast = evaluate_streamed(pose, config, receive_ns=NOW_NS, path=False, atlas=keeper.get(config))
    exact = evaluate_streamed(pose, config, receive_ns=NOW_NS, path=False)
    fm, em = fast.prediction.margins, exact.prediction.margins  # type: ignore[union-attr]
    assert fm is not None
    assert em is not None
    assert fm.angle_minus == pytest.approx(em.angle_minus, abs=1e-5)
    assert fm.lateral_plus == pytest.approx(em.lateral_plus, abs=1e-4 * config.width_m)


def test_with_a_cache_dir_a_restart_loads_the_atlas_instead_of_building_it(
    config: NodeConfig, tmp_path: Any
) -> None:
    cached = replace(config, atlas_cache_dir=str(tmp_path / "atlases"))
    _, built = _ready(cached)
    assert built.build_seconds > 0.0
    assert [f.name for f in (tmp_path / "atlases").iterdir()] == [f"atlas-{built.key}.npz"]
    _, loaded = _ready(cached)  # the node restarted
    assert loaded.build_seconds == 0.0  # read from the file
    assert (loaded.outcomes == built.outcomes).all()


def test_the_node_atlas_knows_every_grid_line_flip(config: NodeConfig) -> None:
    # A planner's first question near a boundary is interpolated, not searched (docs/atlas.md).
    from xface_core.atlas.flips import bisect_every_flip, boundary_segments

    _, atlas = _ready(config)
    assert len(atlas.flips) == len(boundary_segments(atlas.outcomes)) > 0
    assert bisect_every_flip(atlas) == 0


def test_an_unwritable_cache_dir_still_gives_an_atlas_and_says_why(
    config: NodeConfig, tmp_path: Any
) -> None:
    blocked = tmp_path / "blocked"
    blocked.write_text("a file where the directory should be")
    log = Log()
    keeper = AtlasKeeper(log)
    keeper.get(replace(config, atlas_cache_dir=str(blocked / "atlases")))
    keeper.join(timeout_s=600.0)
    assert keeper.state == "ready"
    assert any("not usable" in line for line in log.lines)


def test_a_cache_dir_that_is_a_file_is_refused(tmp_path: Any) -> None:
    target = tmp_path / "f"
    target.write_text("")
    values = {spec.name: spec.default for spec in SPECS} | {"atlas_cache_dir": str(target)}
    with pytest.raises(ConfigError, match="atlas_cache_dir"):
        config_from_values(values)


# --- poses with a covariance (relative_pose_with_covariance) --------------------------------

COV = (0.003**2, 0.0, 0.0, 0.1**2)  # (x, yaw) block: 3 mm, 0.1 rad


def _pose(config: NodeConfig, x_widths: float, theta0: float, cov: Any = COV) -> PoseInput:
    # theta0 = yaw - pi: the quaternion of yaw = theta0 + pi, 3 D above the base.
    half = (theta0 + math.pi) / 2.0
    return PoseInput(
        "xface_base", NOW_NS, (x_widths * config.width_m, 3.0 * config.width_m, 0.0),
        (0.0, 0.0, math.sin(half), math.cos(half)), cov,
    )  # fmt: skip


@pytest.fixture(scope="module")
def atlas(config: NodeConfig) -> xf.AcceptanceAtlas:
    # With every flip, as the node's keeper builds it: its seat probabilities read them.
    return xf.build_atlas(
        config.design, physics=config.physics, lateral_step=1 / 16, angle_step=0.05,
        every_flip=True,
    )  # fmt: skip


def test_a_pose_with_covariance_carries_its_seat_probability(
    config: NodeConfig, atlas: xf.AcceptanceAtlas
) -> None:
    verdict = evaluate_streamed(
        _pose(config, 0.3, 0.2), config, receive_ns=NOW_NS, path=False, atlas=atlas
    )
    p = verdict.decision.seat_probability  # type: ignore[union-attr]
    expected = xf.seat_probability(
        config.design, verdict.start.x0, verdict.start.theta0,  # type: ignore[union-attr]
        [[COV[0], COV[1]], [COV[2], COV[3]]], physics=config.physics, atlas=atlas,
        boundary=SEAT_BOUNDARY,
    )  # fmt: skip
    assert SEAT_BOUNDARY == "atlas"  # the node draws the boundaries from its atlas's flips
    assert p == expected
    assert 0.0 < p < 1.0


def test_below_the_required_seat_probability_it_is_refused_with_a_correction(
    config: NodeConfig, atlas: xf.AcceptanceAtlas
) -> None:
    # 2 cm and 0.2 rad of uncertainty: P(seat) about 0.77; a correction of about 7 mm and
    # 0.08 rad brings it to 0.9.
    strict = replace(config, min_seat_probability=0.9)
    wide = (0.02**2, 0.0, 0.0, 0.2**2)
    verdict = evaluate_streamed(
        _pose(strict, 0.3, 0.2, wide), strict, receive_ns=NOW_NS, path=False, atlas=atlas
    )
    decision = verdict.decision  # type: ignore[union-attr]
    assert verdict.prediction.seated  # type: ignore[union-attr]
    assert not decision.accepted
    assert "seat probability" in decision.why
    assert decision.suggestion is not None


def test_without_an_atlas_a_required_seat_probability_is_not_yet_met(config: NodeConfig) -> None:
    strict = replace(config, min_seat_probability=0.5)
    verdict = evaluate_streamed(_pose(strict, 0.0, 0.0), strict, receive_ns=NOW_NS, path=False)
    assert not verdict.accepted
    assert "not available yet" in verdict.decision.why  # type: ignore[union-attr]


@pytest.mark.parametrize(
    "cov", [(-1.0, 0.0, 0.0, 1.0), (1.0, 0.5, 0.0, 1.0), (1.0, 2.0, 2.0, 1.0), (math.nan,) * 4]
)
def test_a_covariance_that_is_not_one_is_rejected(config: NodeConfig, cov: Any) -> None:
    verdict = evaluate_streamed(_pose(config, 0.0, 0.0, cov), config, receive_ns=NOW_NS, path=False)
    assert verdict.code == "bad_covariance"  # type: ignore[union-attr]


def test_a_restart_reads_every_flip_from_the_cache(config: NodeConfig, tmp_path: Any) -> None:
    from xface_core.atlas.flips import boundary_segments

    cached = replace(config, atlas_cache_dir=str(tmp_path / "atlases"))
    _, built = _ready(cached)
    _, loaded = _ready(cached)  # the node restarted
    assert loaded.build_seconds == 0.0
    assert len(loaded.flips) == len(built.flips) == len(boundary_segments(loaded.outcomes))


def _wait_for_cancel(cancel: Any) -> None:
    """What a long build does between its batches: go on until nobody wants the atlas."""
    deadline = time.monotonic() + 30.0
    while not cancel():
        assert time.monotonic() < deadline, "never cancelled"
        time.sleep(0.005)
    raise Cancelled("cancelled by the caller")


def test_stop_cancels_a_running_build_and_starts_no_more(config: NodeConfig) -> None:
    started = threading.Event()

    def endless(
        design: xf.FaceDesign, physics: xf.Physics, cache_dir: str, cancel: Any
    ) -> xf.AcceptanceAtlas:
        started.set()
        _wait_for_cancel(cancel)
        raise AssertionError("unreachable")

    log = Log()
    keeper = AtlasKeeper(log, build=endless)
    keeper.get(config)
    assert started.wait(30.0)
    keeper.stop(timeout_s=30.0)
    assert not any(t.is_alive() for t in keeper._threads)
    assert not any("failed" in line for line in log.lines)  # a cancelled build is no failure
    threads = len(keeper._threads)
    other = replace(config, design=xf.make_face("V", 0.5, 1.0, width=config.width_m))
    assert keeper.get(other) is None
    assert len(keeper._threads) == threads


def test_a_newer_design_cancels_the_older_build(config: NodeConfig) -> None:
    started = threading.Event()
    cancelled: list[str] = []

    def build(
        design: xf.FaceDesign, physics: xf.Physics, cache_dir: str, cancel: Any
    ) -> xf.AcceptanceAtlas:
        if design.kind == config.design.kind:
            started.set()
            try:
                _wait_for_cancel(cancel)
            finally:
                cancelled.append(design.kind)
        return _coarse(design, physics)

    keeper = AtlasKeeper(Log(), build=build)
    keeper.get(config)
    assert started.wait(30.0)
    other = replace(config, design=xf.make_face("V", 0.5, 1.0, width=config.width_m))
    keeper.get(other)
    keeper.join()
    assert cancelled == [config.design.kind]
    atlas = keeper.get(other)
    assert atlas is not None
    assert atlas.design.kind == "V"
