"""The user-facing interface of xface as one JSON document, to show a change kept it.

    python scripts/evidence/interface_snapshot.py [--write tests/interfaces.json]

What it holds: ``xface_core.__all__``; every ``xface`` command with its options; the key
paths of each command's ``--json`` output on small runs (nested keys joined by ``.``, list
items as ``[]``); the node's parameters with their defaults (``xface_ros.config.SPECS``) and
its topics and services by name and type (``xface_ros.names``), no ROS imported.
``tests/test_interfaces.py`` compares the working tree's snapshot with the stored one; the
node's topics and services are checked over DDS in ``tests/ros/test_interface_names.py``
against the same file.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import tempfile
from pathlib import Path
from typing import Any

#: Small runs of every command that writes JSON (the grid kept small: seconds in all).
JSON_RUNS: dict[str, list[str]] = {
    "predict": ["predict", "--face", "X", "--x0", "0.3", "--theta0", "0.2"],
    "predict --no-margins": ["predict", "--x0", "0.3", "--theta0", "0.2", "--no-margins"],
    "predict --sigma": ["predict", "--face", "S", "--x0", "0.2", "--theta0", "0.1",
                        "--sigma-x", "0.05", "--sigma-theta", "0.05"],
    "predict --sigma (correction)": ["predict", "--x0", "0.9", "--theta0", "1.2",
                                     "--sigma-x", "0.1", "--sigma-theta", "0.1"],
    "map": ["map", "--face", "V", "--grid", "11", "--quiet"],
    "compare": ["compare", "--face", "X", "--vs-face", "S", "--grid", "11"],
    "table": ["table", "--face", "V", "--method", "bound", "--quiet"],
}  # fmt: skip
#: Commands that write a folder: run with ``--out`` in a temporary directory.
OUT_RUNS: dict[str, list[str]] = {
    "sweep": ["sweep", "--face", "X", "--h-over-d", "1", "--rp", "0,1", "--grid", "5",
              "--workers", "1", "--quiet"],
    "design": ["design", "--face", "V", "--steps", "2", "--refine", "0", "--grid", "5",
               "--workers", "1", "--quiet"],
}  # fmt: skip


def key_paths(value: Any, prefix: str = "") -> set[str]:
    """Every key path of a JSON value: ``a.b`` for nested objects, ``a[]`` for list items."""
    if isinstance(value, dict):
        out: set[str] = set()
        for key, item in value.items():
            path = f"{prefix}.{key}" if prefix else str(key)
            out |= {path} | key_paths(item, path)
        return out
    if isinstance(value, list):
        return set().union(*(key_paths(item, f"{prefix}[]") for item in value)) if value else set()
    return set()


def commands() -> dict[str, list[str]]:
    """Each ``xface`` command and its option strings (positionals by their name)."""
    from xface_core.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    out = {"": sorted(s for a in parser._actions for s in a.option_strings)}
    for name, command in sorted(sub.choices.items()):
        out[name] = sorted(s for a in command._actions for s in (a.option_strings or [a.dest]))
    return out


def json_keys() -> dict[str, list[str]]:
    """The key paths of each run's ``--json`` output."""
    from xface_core.cli import main

    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        runs = dict(JSON_RUNS)
        runs |= {k: [*v, "--out", str(Path(tmp) / k)] for k, v in OUT_RUNS.items()}
        for label, argv in runs.items():
            stdout = io.StringIO()
            with contextlib.redirect_stdout(stdout):
                code = main([*argv, "--json"])
            if code != 0:
                raise SystemExit(f"xface {' '.join(argv)} --json exited {code}")
            out[label] = sorted(key_paths(json.loads(stdout.getvalue())))
    return out


def ros_parameters() -> dict[str, Any]:
    from xface_ros.config import SPECS

    return {spec.name: spec.default for spec in SPECS}


def ros_interface() -> dict[str, Any]:
    """The node's topics and services by name and type (``xface_ros.names``, no ROS imported),
    and which of them need the typed interface ``xface_msgs``."""
    from xface_ros import names

    return {
        "publishes": dict(names.PUBLISHES),
        "subscribes": dict(names.SUBSCRIBES),
        "serves": dict(names.SERVES),
        "typed": sorted(names.TYPED),
    }


def snapshot() -> dict[str, Any]:
    import xface_core

    return {
        "xface_core.__all__": sorted(xface_core.__all__),
        "commands": commands(),
        "json_keys": json_keys(),
        "ros_parameters": ros_parameters(),
        "ros_interface": ros_interface(),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", type=Path, help="write the snapshot here (default: stdout)")
    args = parser.parse_args(argv)
    text = json.dumps(snapshot(), indent=1, sort_keys=True) + "\n"
    if args.write is None:
        sys.stdout.write(text)
    else:
        args.write.write_text(text, "utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
