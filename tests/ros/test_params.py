"""Parameter specs, descriptors and validation, without starting DDS."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest
import yaml
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.parameter import Parameter

from xface_core.facefile import save_face
from xface_core.geometry import make_face
from xface_ros.config import normalise_frame_id, params_file_applied, params_file_paths
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
