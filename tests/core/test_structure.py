"""Shape rules of the core: short functions, no import cycles, a private engine that stays
private, and a ``simulate`` that reads as a list of stages."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

CORE = Path(__file__).resolve().parents[2] / "xface_core"

#: Longest function allowed in xface_core (lines from ``def`` to its end, docstring included).
MAX_FUNCTION_LINES = 120


def _modules() -> dict[str, ast.Module]:
    out = {}
    for path in sorted(CORE.rglob("*.py")):
        rel = path.relative_to(CORE.parent).with_suffix("")
        name = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
        out[name] = ast.parse(path.read_text(), filename=str(path))
    return out


MODULES = _modules()


def _imports(name: str, tree: ast.Module) -> set[str]:
    """xface_core modules imported anywhere in ``tree`` (function-level imports included)."""
    base = (name if _is_package(name) else name.rpartition(".")[0]).split(".")
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                parts = base[: len(base) - node.level + 1]
                target = ".".join(parts + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            # ``from . import x`` imports the module x, not its package's __init__.
            names = [f"{target}.{a.name}" for a in node.names]
            candidates = [*names, target] if node.module else names
        elif isinstance(node, ast.Import):
            candidates = [a.name for a in node.names]
        else:
            continue
        found.update(c for c in candidates if c in MODULES and c != name)
    return found


def _is_package(name: str) -> bool:
    return (CORE.parent / name.replace(".", "/") / "__init__.py").exists()


GRAPH = {name: _imports(name, tree) for name, tree in MODULES.items()}


def _functions() -> list[tuple[str, str, int]]:
    rows = []
    for name, tree in MODULES.items():
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                assert node.end_lineno is not None
                rows.append((name, node.name, node.end_lineno - node.lineno + 1))
    return rows


def test_the_module_scan_sees_the_engine() -> None:
    assert "xface_core._engine.simulate" in MODULES
    assert "xface_core._engine.records" in GRAPH["xface_core._engine.simulate"]


@pytest.mark.parametrize(("module", "function", "lines"), _functions())
def test_function_fits_a_screen(module: str, function: str, lines: int) -> None:
    assert lines <= MAX_FUNCTION_LINES, f"{module}.{function} has {lines} lines"


def test_no_import_cycles_in_the_core() -> None:
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node: str) -> None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(GRAPH[node]):
            if state.get(nxt) == 1:
                cycle = [*path[path.index(nxt) :], nxt]
                pytest.fail("import cycle: " + " -> ".join(cycle))
            if nxt not in state:
                visit(nxt)
        path.pop()
        state[node] = 2

    for module in sorted(GRAPH):
        if module not in state:
            visit(module)


def test_margins_build_on_predictions_not_the_other_way_round() -> None:
    assert "xface_core.predict" not in GRAPH["xface_core.margins"]
    assert "xface_core.margins" in GRAPH["xface_core.predict"]


def test_the_engine_depends_only_on_codes_and_physics() -> None:
    for module, deps in GRAPH.items():
        if module.startswith("xface_core._engine"):
            outside = {d for d in deps if not d.startswith("xface_core._engine")}
            assert outside <= {"xface_core.codes", "xface_core.physics"}, module


def test_only_the_typed_bridge_uses_the_engine() -> None:
    users = {
        m
        for m, deps in GRAPH.items()
        if not m.startswith("xface_core._engine")
        and any(d.startswith("xface_core._engine") for d in deps)
    }
    # precompile is the engine's build step: it writes the build's manifest.
    assert users <= {"xface_core.runner", "xface_core.contact", "xface_core.precompile"}


def test_simulate_reads_as_a_list_of_stages() -> None:
    tree = MODULES["xface_core._engine.simulate"]
    (fn,) = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == "simulate"]
    calls = [
        n.func.id for n in ast.walk(fn) if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)
    ]
    # The scratch arrays come from the caller (new_work per pose, or one per batch).
    stages = ["start_run", "begin_interval", "approach", "follow_contacts"]
    assert [c for c in calls if c in stages] == stages
    body_lines = fn.body[-1].end_lineno - fn.body[1].lineno + 1  # without the docstring
    assert body_lines <= 15
