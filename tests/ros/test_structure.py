"""Shape rules of the node, as tests/core/test_structure.py has them for the core: short
functions, no import cycles between its modules, and no reach into the core's private engine.

Read from the sources (``ast``), so nothing here imports a module of the node.
"""

from __future__ import annotations

import ast
import graphlib
from pathlib import Path

import pytest

NODE = Path(__file__).resolve().parents[2] / "xface_ros"

#: Longest function allowed (lines from ``def`` to its end, docstring included): the core's.
MAX_FUNCTION_LINES = 120

TREES = {
    f"xface_ros.{path.stem}": ast.parse(path.read_text(), filename=str(path))
    for path in sorted(NODE.glob("*.py"))
    if path.stem != "__init__"
}


def _imported(module: str, tree: ast.Module) -> set[str]:
    """Every module ``tree`` imports, at any depth (function-level and TYPE_CHECKING imports
    included), as dotted names; ``from a import b`` counts as a and as a.b."""
    package = module.rpartition(".")[0].split(".")
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            stem = package[: len(package) - node.level + 1] if node.level else []
            source = ".".join([*stem, *([node.module] if node.module else [])])
            found.add(source)
            found.update(f"{source}.{alias.name}" for alias in node.names)
    return found


IMPORTS = {module: _imported(module, tree) for module, tree in TREES.items()}
#: Which of the node's modules each of them imports.
GRAPH = {module: (deps & TREES.keys()) - {module} for module, deps in IMPORTS.items()}


def test_the_scan_sees_every_module_and_function_level_imports() -> None:
    assert {"xface_ros.node", "xface_ros.worker", "xface_ros.log"} <= TREES.keys()
    assert "xface_ros.node" in GRAPH["xface_ros.demo"]  # imported inside main's steps
    assert "xface_ros.log" in GRAPH["xface_ros.recorder"]


def test_no_import_cycles_in_the_node() -> None:
    try:
        tuple(graphlib.TopologicalSorter(GRAPH).static_order())
    except graphlib.CycleError as exc:
        pytest.fail("import cycle: " + " -> ".join(exc.args[1]))


def test_the_logger_protocol_imports_nothing_of_the_node() -> None:
    assert GRAPH["xface_ros.log"] == set()


def test_the_node_uses_no_private_engine_module() -> None:
    users = {
        module: sorted(d for d in deps if d.startswith("xface_core._engine"))
        for module, deps in IMPORTS.items()
    }
    assert {m: d for m, d in users.items() if d} == {}


#: (module, function, lines) of every function and method, nested ones included.
FUNCTIONS = [
    (module, node.name, (node.end_lineno or node.lineno) - node.lineno + 1)
    for module, tree in TREES.items()
    for node in ast.walk(tree)
    if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
]


@pytest.mark.parametrize(("module", "function", "lines"), FUNCTIONS)
def test_function_fits_a_screen(module: str, function: str, lines: int) -> None:
    assert lines <= MAX_FUNCTION_LINES, f"{module}.{function} has {lines} lines"
