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
    assert "xface_core.predict" not in GRAPH["xface_core.atlas.margins"]
    assert "xface_core.atlas.margins" in GRAPH["xface_core.predict"]


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


#: Most modules directly in ``xface_core/`` besides its packages (``__init__.py`` not counted):
#: the ground, the bridge to the engine and the front door; every question has its package.
MAX_TOP_MODULES = 15

#: The core's layers, top-down: a module imports modules of its own group, of the ground, or
#: of a layer below its own. A group is a top module or a subpackage.
LAYERS: tuple[frozenset[str], ...] = (
    frozenset({"cli", "precompile"}),  # the commands
    frozenset({"__init__"}),  # the package's front: what ``import xface_core`` gives
    frozenset({"study", "crosscheck", "viz"}),  # many designs; presentation and the check
    frozenset({"maps"}),  # one design's grid
    frozenset({"predict"}),  # one pose: the front door, margins included
    frozenset({"atlas"}),  # the questions around one pose
    frozenset({"runner"}),  # the typed bridge to the engine
    frozenset({"result"}),
    frozenset({"contact"}),
    frozenset({"_engine"}),
)
#: The ground: codes, errors and the values every layer shares (acyclic among themselves,
#: which the cycle test checks).
GROUND = frozenset({"codes", "errors", "physics", "geometry", "facefile", "frames", "data"})


def _group(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def _rank(group: str) -> int:
    if group in GROUND:
        return -1
    for depth, layer in enumerate(LAYERS):
        if group in layer:
            return len(LAYERS) - depth
    raise AssertionError(f"{group} is in no layer of test_structure.LAYERS")


def test_the_top_of_the_core_holds_at_most_fifteen_modules() -> None:
    top = [p.name for p in CORE.glob("*.py") if p.name != "__init__.py"]
    assert len(top) <= MAX_TOP_MODULES, sorted(top)


def test_every_group_of_the_core_has_a_layer() -> None:
    for module in MODULES:
        _rank(_group(module))


def _upward(module: str, deps: set[str]) -> list[str]:
    """The imports of ``module`` that go to a layer at or above its own."""
    group = _group(module)
    return sorted(
        dep
        for dep in deps
        if _group(dep) != group
        and _rank(_group(dep)) >= _rank(group)
        and not (group in GROUND and _group(dep) in GROUND)
    )


@pytest.mark.parametrize("module", sorted(GRAPH))
def test_imports_read_top_down(module: str) -> None:
    assert _upward(module, GRAPH[module]) == [], f"{module} imports a layer at or above its own"


def test_the_layer_rule_sees_an_upward_import() -> None:
    deps = {"xface_core.atlas.build", "xface_core.codes", "xface_core.runner"}
    assert _upward("xface_core.runner", deps) == ["xface_core.atlas.build"]
    assert _upward("xface_core.atlas.margins", {"xface_core.predict"}) == ["xface_core.predict"]
    assert _upward("xface_core.geometry", {"xface_core.errors"}) == []
