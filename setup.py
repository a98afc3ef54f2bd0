"""setuptools' hook: the wheel carries the precompiled engine; colcon's entry point too.

pip builds from pyproject.toml (this file only adds the build step below); ``setup.cfg`` adds
what colcon needs (the package name for setuptools 68, the ament index marker and
package.xml).

``build_py`` copies the packages into the build folder, then compiles the engine there
(``python -m xface_core.precompile``, a minute or two of CPU), so that a wheel, ``pip install
.`` and ``pip install -e .`` answer their first query in seconds instead of compiling first.
An editable install writes it into the source tree (``xface_core/_engine/_compiled``, ignored
by git). A failed compile does not fail the install: the engine then compiles on first use,
as ``xface --version`` says. ``XFACE_PRECOMPILE=0`` skips the step, ``XFACE_PRECOMPILE=require``
(``make setup``) makes a failed one fail the install.
"""

from __future__ import annotations

import os
import subprocess
import sys
from importlib.util import find_spec
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

#: Where the precompiled engine goes inside the package tree.
COMPILED = Path("xface_core", "_engine", "_compiled")


class BuildPyWithEngine(build_py):  # type: ignore[misc]
    """``build_py``, then the precompiled engine beside the copied sources."""

    def run(self) -> None:
        super().run()
        mode = os.environ.get("XFACE_PRECOMPILE", "1")
        if mode == "0":
            print("xface: XFACE_PRECOMPILE=0: the engine compiles on first use", flush=True)
            return
        missing = [m for m in ("numpy", "numba", "shapely", "yaml") if find_spec(m) is None]
        if missing:  # a build without the core's dependencies (colcon's own environment)
            _give_up(f"no {', '.join(missing)} in the build's environment", mode)
            return
        root = Path(__file__).resolve().parent if self.editable_mode else Path(self.build_lib)
        print("xface: precompiling the engine (about 1-2 minutes of CPU)", flush=True)
        # pip's isolated build environment reaches its packages through PYTHONPATH: keep it.
        paths = [str(root), *filter(None, [os.environ.get("PYTHONPATH")])]
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(paths))
        done = subprocess.run(
            [sys.executable, "-m", "xface_core.precompile", str(root / COMPILED)],
            env=env,
            check=False,
        )
        if done.returncode != 0:
            _give_up(f"python -m xface_core.precompile exited {done.returncode}", mode)


def _give_up(why: str, mode: str) -> None:
    """Without a precompiled engine the install still works (it compiles on first use), so
    only ``XFACE_PRECOMPILE=require`` (``make setup``, hence CI) makes it an error."""
    message = f"xface: could not precompile the engine ({why})"
    if mode == "require":
        raise SystemExit(f"{message}; XFACE_PRECOMPILE=require")
    print(f"{message}; it compiles on first use", file=sys.stderr, flush=True)


if __name__ == "__main__":
    # No keyword arguments: colcon reads setup()'s arguments back as Python literals and
    # fails on a command class; pyproject.toml names BuildPyWithEngine instead
    # ([tool.setuptools.cmdclass], which imports this file as the module ``setup``).
    setup()
