"""docs/architecture.md names every module of xface_core and xface_ros, and no module that is gone.

The rule: every ``*.py`` file under ``xface_core/`` and ``xface_ros/`` (``__init__.py`` and
``__main__.py`` excepted, as are ``__pycache__`` and the precompiled engine's folder) is a
module of its package, the folder it sits in (``xface_core``, ``xface_core/_engine``,
``xface_core/viz``, ``xface_core/crosscheck``, ``xface_ros``). Each package has one section in
docs/architecture.md: the ``## `` heading that names the package's folder in backticks with a
trailing slash, e.g. ``## The engine, `xface_core/_engine/` ``. A module is documented when
its file name in backticks (``name.py``) appears in the first cell of a table row (a line
starting with ``|``) of its package's section, several names to a cell allowed
(``| `sweep.py`, `bounds.py` | ...``). Conversely, every such name in a section's first
column must be a module of that package. A module's own line says what it is (its docstring).
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "architecture.md"
PACKAGES = ("xface_core", "xface_ros")
#: Not modules of their own: package markers, entry scripts, build output.
EXCLUDED_NAMES = {"__init__.py", "__main__.py"}
EXCLUDED_DIRS = {"__pycache__", "_compiled"}

_HEADING = re.compile(r"^## (.*)$")
_PACKAGE_IN_HEADING = re.compile(r"`([A-Za-z_][\w/]*)/`")
_NAME_IN_CELL = re.compile(r"`([A-Za-z_]\w*\.py)`")


def modules() -> dict[str, set[str]]:
    """Each package folder (relative, with ``/``) and the file names of its modules."""
    found: dict[str, set[str]] = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            rel = path.relative_to(ROOT)
            if path.name in EXCLUDED_NAMES or EXCLUDED_DIRS & set(rel.parts[:-1]):
                continue
            found.setdefault(rel.parent.as_posix(), set()).add(path.name)
    return found


def documented(text: str) -> dict[str, set[str]]:
    """Each package folder named in a ``## `` heading and the module names in the first cells
    of its section's table rows."""
    sections: dict[str, set[str]] = {}
    current: set[str] | None = None
    for line in text.splitlines():
        heading = _HEADING.match(line)
        if heading:
            named = _PACKAGE_IN_HEADING.findall(heading.group(1))
            current = sections.setdefault(named[0], set()) if named else None
            continue
        if current is not None and line.startswith("|"):
            first_cell = line.split("|")[1]
            current.update(_NAME_IN_CELL.findall(first_cell))
    return sections


def test_the_rule_finds_the_packages_and_their_modules() -> None:
    found = modules()
    assert {"xface_core", "xface_core/_engine", "xface_core/viz", "xface_core/crosscheck",
            "xface_ros"} <= set(found)  # fmt: skip
    assert "simulate.py" in found["xface_core/_engine"]
    assert "__init__.py" not in found["xface_core"]
    assert "__main__.py" not in found["xface_ros"]


def test_documented_reads_sections_and_first_cells() -> None:
    text = (
        "## `pkg/`, from the bottom up\n\n| module | what |\n|---|---|\n"
        "| `a.py`, `b.py` | mentions `c.py` in the second cell |\n"
        "## Changing it\n\n| `d.py` | outside any package section |\n"
        "## The engine, `pkg/_engine/`\n\n| `e.py` | ... |\n"
    )
    assert documented(text) == {"pkg": {"a.py", "b.py"}, "pkg/_engine": {"e.py"}}


def test_every_module_is_in_its_packages_section() -> None:
    sections = documented(DOC.read_text(encoding="utf-8"))
    missing = [
        f"{package}/{name}"
        for package, names in sorted(modules().items())
        for name in sorted(names - sections.get(package, set()))
    ]
    assert missing == [], "add a table row for each to docs/architecture.md"


def test_every_module_the_document_names_exists() -> None:
    found = modules()
    sections = documented(DOC.read_text(encoding="utf-8"))
    stale = [
        f"{package}/{name}"
        for package, names in sorted(sections.items())
        for name in sorted(names - found.get(package, set()))
    ]
    assert stale == [], "docs/architecture.md names modules that do not exist"
