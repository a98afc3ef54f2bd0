"""The user-facing interface kept: ``xface_core.__all__``, the commands and their options, the
keys of every command's JSON output and the node's parameters, against ``tests/interfaces.json``.

The stored file was written before the core's regroup (on fe80e66, the last commit of the flat
layout) by ``scripts/evidence/interface_snapshot.py --write tests/interfaces.json``; a change
that means to extend the interface rewrites it in the same commit and says so. The node's
topics and services were added on 2026-11-29 from ``xface_ros.names``, the lists the DDS check
(tests/ros/test_interface_names.py) held until then, unchanged; that check now reads them here.
"""

from __future__ import annotations

import importlib
import importlib.util
import json
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]
STORED: dict[str, Any] = json.loads((ROOT / "tests" / "interfaces.json").read_text("utf-8"))


def _script() -> ModuleType:
    spec = importlib.util.spec_from_file_location(
        "interface_snapshot", ROOT / "scripts" / "evidence" / "interface_snapshot.py"
    )
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


SNAPSHOT = _script()


def test_the_package_exports_the_same_names() -> None:
    import xface_core

    assert sorted(xface_core.__all__) == STORED["xface_core.__all__"]


def test_every_command_keeps_its_options() -> None:
    assert SNAPSHOT.commands() == STORED["commands"]


def test_every_json_output_keeps_its_keys() -> None:
    assert SNAPSHOT.json_keys() == STORED["json_keys"]


def test_the_node_keeps_its_parameters_and_defaults() -> None:
    pytest.importorskip("xface_ros.config")
    assert SNAPSHOT.ros_parameters() == STORED["ros_parameters"]


def test_the_node_keeps_its_topics_and_services() -> None:
    pytest.importorskip("xface_ros.names")
    assert SNAPSHOT.ros_interface() == STORED["ros_interface"]


def test_key_paths_name_nested_keys_and_list_items() -> None:
    value = {"a": {"b": 1}, "c": [{"d": 2}, {"e": 3}], "f": []}
    assert SNAPSHOT.key_paths(value) == {"a", "a.b", "c", "c[].d", "c[].e", "f"}


@pytest.mark.parametrize(
    ("package", "module"),
    [("xface_core.atlas", "xface_core.atlas.build"), ("xface_core.study", "xface_core.study.run")],
)
def test_a_package_in_place_of_a_module_exports_what_it_did(package: str, module: str) -> None:
    pkg, mod = importlib.import_module(package), importlib.import_module(module)
    assert pkg.__all__ == mod.__all__
    assert all(getattr(pkg, name) is getattr(mod, name) for name in mod.__all__)


def test_the_command_line_package_runs_as_the_module_did() -> None:
    from xface_core import cli
    from xface_core.cli import commands

    assert cli.main is commands.main
    assert cli.build_parser is commands.build_parser
