"""Parameter specs, descriptors and validation, without starting DDS."""

from __future__ import annotations

import math
import os
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.parameter import Parameter

from xface_core.facefile import save_face
from xface_core.geometry import make_face
from xface_ros import config as config_module
from xface_ros.config import NodeConfig, normalise_frame_id, params_file_applied, params_file_paths
from xface_ros.params import (
    DESIGN_PARAMETERS,
    SPECS,
    ConfigError,
    config_from_values,
    default_record_path,
    descriptor,
    merged_values,
)

ROOT = Path(__file__).resolve().parents[2]


def defaults() -> dict[str, Any]:
    return {spec.name: spec.default for spec in SPECS}


def test_issue_parameter_names_are_all_declared() -> None:
    names = {spec.name for spec in SPECS}
    required = {
        "face", "width_m", "h_over_d", "r_p", "damping_ratio", "friction", "base_frame",
        "input_timeout_s", "min_margin", "record", "record_path", "record_url",
    }  # fmt: skip
    assert required <= names
    assert names >= DESIGN_PARAMETERS


def test_every_parameter_has_a_description_and_numbers_have_a_range() -> None:
    for spec in SPECS:
        desc: ParameterDescriptor = descriptor(spec)
        assert desc.description, spec.name
        if isinstance(spec.default, float):
            assert len(desc.floating_point_range) == 1, spec.name
            low, high = spec.float_range or (math.nan, math.nan)
            assert low <= spec.default <= high, spec.name
        if isinstance(spec.default, int) and not isinstance(spec.default, bool):
            assert len(desc.integer_range) == 1, spec.name


def test_recording_diagnostics_period_and_atlas_cache_are_read_only() -> None:
    read_only = {spec.name for spec in SPECS if descriptor(spec).read_only}
    assert read_only == {
        "record", "record_path", "record_url", "diagnostics_period_s", "atlas_cache_dir"
    }  # fmt: skip


def test_params_file_repeats_the_built_in_defaults() -> None:
    data = yaml.safe_load((ROOT / "config" / "xface.yaml").read_text(encoding="utf-8"))
    from_file = data["/**"]["ros__parameters"]
    assert from_file == defaults()


def test_defaults_build_the_x_face_in_metres() -> None:
    config = config_from_values(defaults())
    assert config.design.kind == "X"
    assert config.design.width == pytest.approx(0.05)
    expected = make_face("X", 0.25, 1.0, width=0.05)
    assert config.design.mated_distance == expected.mated_distance


@pytest.mark.parametrize(
    ("name", "value", "match"),
    [
        ("face", "Q", "face must be one of"),
        ("width_m", 0.0, "width_m"),
        ("width_m", math.nan, "width_m"),
        ("h_over_d", 1000.0, "h_over_d"),
        ("r_p", -1.0, "r_p"),
        ("damping_ratio", 0.0, "damping_ratio"),
        ("input_timeout_s", -0.1, "input_timeout_s"),
        ("max_path_poses", 1, "max_path_poses"),
        ("base_frame", "", "base_frame"),
        ("base_frame", "/", "base_frame"),
        ("base_frame", "two words", "base_frame"),
        ("width_m", "wide", "width_m must be a float"),
        ("record", 1, "record must be a bool"),
    ],
)
def test_invalid_values_are_refused_with_the_parameter_named(
    name: str, value: object, match: str
) -> None:
    with pytest.raises(ConfigError, match=match):
        config_from_values({**defaults(), name: value})


def test_negative_friction_is_refused_with_the_cores_reason() -> None:
    with pytest.raises(ConfigError, match="friction"):
        config_from_values({**defaults(), "friction": -0.3})


def test_friction_is_passed_to_the_simulator() -> None:
    assert config_from_values({**defaults(), "friction": 0.3}).friction == 0.3


def test_base_frame_loses_its_leading_slash() -> None:
    assert (
        config_from_values({**defaults(), "base_frame": "/xface_base"}).base_frame == "xface_base"
    )


def test_face_letter_is_case_insensitive() -> None:
    assert config_from_values({**defaults(), "face": "v"}).design.kind == "V"


def test_integer_value_for_a_double_parameter_is_accepted() -> None:
    assert config_from_values({**defaults(), "r_p": 2}).r_p == 2.0


def test_record_path_that_is_a_directory_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="directory"):
        config_from_values({**defaults(), "record_path": str(tmp_path)})


def test_merged_values_overlays_changes_and_ignores_foreign_parameters() -> None:
    merged = merged_values(
        defaults(), [Parameter("face", value="S"), Parameter("use_sim_time", value=True)]
    )
    assert merged["face"] == "S"
    assert "use_sim_time" not in merged
    assert merged["width_m"] == defaults()["width_m"]


def test_margins_are_needed_when_a_margin_is_required() -> None:
    off = config_from_values({**defaults(), "compute_margins": False})
    assert not off.need_margins
    required = config_from_values({**defaults(), "compute_margins": False, "min_margin": 0.01})
    assert required.need_margins


def test_default_record_path_is_a_timestamped_rrd_in_the_working_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    path = Path(default_record_path(0.0))
    assert path.parent == tmp_path
    assert path.name.startswith("xface-")
    assert path.suffix == ".rrd"


def test_docs_list_every_parameter_with_its_default() -> None:
    docs = (ROOT / "docs" / "ros.md").read_text(encoding="utf-8")
    rows = {
        line.split("|")[1].strip().strip("`"): line
        for line in docs.splitlines()
        if line.startswith("| `")
    }
    for spec in SPECS:
        assert spec.name in rows, spec.name
        default = spec.default
        if isinstance(default, bool):
            text = "true" if default else "false"
        elif isinstance(default, str):
            text = f'"{default}"'
        else:
            text = repr(default)
        assert f"`{text}`" in rows[spec.name], (spec.name, text)


def test_params_files_are_read_from_the_ros_arguments_only() -> None:
    argv = ["prog", "--params-file", "not_ros.yaml", "--ros-args", "-r", "__ns:=/left",
            "--params-file", "a.yaml", "--", "--ros-args", "--params-file", "b.yaml"]  # fmt: skip
    assert params_file_paths(argv) == ["a.yaml", "b.yaml"]


def test_a_params_file_applies_when_one_of_its_values_reached_the_node() -> None:
    assert params_file_applied({"width_m": 0.08, "face": "V"}, {"face": "V"})


def test_a_params_file_keyed_for_another_node_applies_nothing() -> None:
    assert not params_file_applied({"width_m": 0.08}, {})


def test_frame_ids_compare_without_their_leading_slash() -> None:
    assert normalise_frame_id("/xface_base") == normalise_frame_id("xface_base") == "xface_base"


def test_a_custom_face_needs_a_face_file() -> None:
    with pytest.raises(ConfigError, match="face custom needs face_file"):
        config_from_values({**defaults(), "face": "custom"})


def test_a_custom_face_takes_its_design_and_width_from_the_file(tmp_path: Path) -> None:
    design = make_face("V", 0.5, 1.0, width=0.08)
    path = save_face(design, tmp_path / "v.yaml")
    config = config_from_values({**defaults(), "face": "Custom", "face_file": str(path)})
    assert config.face == "custom"
    assert config.width_m == 0.08
    assert config.design.mated_distance == design.mated_distance


def test_a_kept_design_is_used_without_reading_the_face_file(tmp_path: Path) -> None:
    kept = make_face("V", 0.5, 1.0, width=0.08)
    config = config_from_values(custom(str(tmp_path / "missing.yaml")), design=kept)
    assert config.design is kept
    assert config.width_m == 0.08


# --- a face file the node cannot use is a refusal, never a crash or a hang ------------------


def custom(face_file: str) -> dict[str, Any]:
    return {**defaults(), "face": "custom", "face_file": face_file}


#: How long a test waits for a face file read that should be refused at once before it
#: unblocks the read itself (the test then fails): a hang guard, not a timing assertion.
HANG_GUARD_S = 30.0


def outcome_unless_it_hangs(
    values: dict[str, Any], unblock: Callable[[], None]
) -> NodeConfig | BaseException:
    """``config_from_values(values)``'s config or exception; if it is still running after
    ``HANG_GUARD_S``, ``unblock()`` is called to end it and the test fails."""
    outcome: list[NodeConfig | BaseException] = []

    def run() -> None:
        try:
            outcome.append(config_from_values(values))
        except BaseException as exc:
            outcome.append(exc)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(HANG_GUARD_S)
    if thread.is_alive():
        unblock()
        thread.join(HANG_GUARD_S)
        pytest.fail("reading the face file blocked")
    return outcome[0]


def test_a_fifo_face_file_is_refused_without_being_opened(tmp_path: Path) -> None:
    fifo = tmp_path / "face.yaml"
    os.mkfifo(fifo)

    def open_a_writer() -> None:  # what a blocked open(fifo) waits for
        with open(fifo, "w", encoding="utf-8"):
            pass

    result = outcome_unless_it_hangs(custom(str(fifo)), open_a_writer)
    assert isinstance(result, ConfigError), result
    assert str(result).startswith(f"face_file: {str(fifo)!r} is a FIFO, not a regular file")


@pytest.mark.parametrize(
    ("path", "kind"), [("/dev/zero", "a character device"), (".", "a directory")]
)
def test_a_device_or_directory_face_file_is_refused_without_being_read(
    path: str, kind: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    def must_not_read(_path: Any) -> Any:
        raise AssertionError("the face file was read")

    monkeypatch.setattr(config_module, "load_face", must_not_read)
    with pytest.raises(ConfigError, match=f"^face_file: '{path}' is {kind}, not a regular file"):
        config_from_values(custom(path))


def test_a_deeply_nested_face_file_is_refused_with_the_reason(tmp_path: Path) -> None:
    deep = tmp_path / "deep.yaml"
    deep.write_text("[" * 10_000 + "]" * 10_000 + "\n", encoding="utf-8")
    # The loader's own limit (xface_core.facefile.MAX_NESTING_DEPTH) refuses it; the node's
    # catch of a RecursionError words it otherwise: either is the reason, on one line.
    reason = r"(it is nested too deeply|nesting deeper than MAX_NESTING_DEPTH)"
    with pytest.raises(ConfigError, match=rf"^face_file: .*deep\.yaml.*: {reason}"):
        config_from_values(custom(str(deep)))


def test_a_face_file_with_a_5000_digit_width_is_refused_with_the_reason(tmp_path: Path) -> None:
    good = save_face(make_face("X", 0.25, 1.0, width=0.05), tmp_path / "good.yaml")
    wide = tmp_path / "wide.yaml"
    wide.write_text(
        good.read_text(encoding="utf-8").replace("width: 0.05", "width: " + "9" * 5000),
        encoding="utf-8",
    )
    with pytest.raises(ConfigError, match=r"^face_file: .*wide\.yaml") as refused:
        config_from_values(custom(str(wide)))
    assert "\n" not in str(refused.value)


def test_a_face_file_that_is_not_yaml_is_refused_on_one_line(tmp_path: Path) -> None:
    broken = tmp_path / "broken.yaml"
    broken.write_text("xface_face: 1\nlayers: [[\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=r"^face_file: .*broken\.yaml") as refused:
        config_from_values(custom(str(broken)))
    assert "\n" not in str(refused.value)


@settings(max_examples=50)
@given(
    error=st.sampled_from(
        [RecursionError, MemoryError, ValueError, OSError, KeyError, TypeError, RuntimeError]
    ),
    message=st.text(),
)
def test_whatever_loading_a_face_file_raises_is_a_one_line_refusal_naming_the_file(
    error: type[Exception], message: str
) -> None:
    def load_face(_path: Any) -> Any:
        raise error(message)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(config_module, "load_face", load_face)
        with pytest.raises(ConfigError) as refused:
            config_from_values(custom(__file__))  # a regular file: the loader is reached
    reason = str(refused.value)
    assert reason.startswith(f"face_file: cannot load the face file {__file__!r}: ")
    assert len(reason.splitlines()) == 1


def test_a_face_file_that_does_not_load_in_time_is_refused_and_reads_one_at_a_time(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    good = save_face(make_face("V", 0.5, 1.0, width=0.08), tmp_path / "v.yaml")
    release = threading.Event()
    real_load_face = config_module.load_face

    def slow_load_face(path: Any) -> Any:
        release.wait(HANG_GUARD_S)
        return real_load_face(path)

    monkeypatch.setattr(config_module, "load_face", slow_load_face)
    monkeypatch.setattr(config_module, "FACE_FILE_TIMEOUT_S", 0.1, raising=False)
    guard = threading.Timer(HANG_GUARD_S, release.set)  # ends a read that did not time out
    guard.start()
    try:
        with pytest.raises(ConfigError, match=r"^face_file: reading the face file .* took more"):
            config_from_values(custom(str(good)))
        # The first read still runs: the next waits for it, not beside it.
        with pytest.raises(ConfigError, match=r"^face_file: an earlier face file is still being"):
            config_from_values(custom(str(good)))
    finally:
        release.set()
        guard.cancel()
    monkeypatch.setattr(config_module, "FACE_FILE_TIMEOUT_S", HANG_GUARD_S, raising=False)
    deadline = time.monotonic() + HANG_GUARD_S
    while True:  # once the first read has ended, the file loads
        try:
            assert config_from_values(custom(str(good))).width_m == 0.08
            break
        except ConfigError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.01)


# --- parameters the node does not have -------------------------------------------------------


def test_an_unknown_parameter_is_named_with_the_closest_known_name() -> None:
    message = config_module.unknown_parameters_message(
        ["widht_m", "face", "zzz_unrelated"], [spec.name for spec in SPECS]
    )
    assert message == (
        "unknown parameters, ignored: widht_m (did you mean width_m?), zzz_unrelated"
    )


def test_no_unknown_parameter_no_message() -> None:
    names = [spec.name for spec in SPECS]
    assert config_module.unknown_parameters_message(names, [*names, "use_sim_time"]) is None


def test_docs_give_the_face_file_time_bound_the_node_uses() -> None:
    docs = (ROOT / "docs" / "ros.md").read_text(encoding="utf-8")
    bound = config_module.FACE_FILE_TIMEOUT_S
    assert f"a read not over after {bound:g} s is refused" in docs
    assert f"took more than {bound:g} s" in docs
