#!/usr/bin/env python3
"""Is a face search's gain the face's, or the grid's? The best face against the X-Face on grids
the search never saw.

    .venv/bin/python scripts/evidence/face_search_check.py SEARCH_FOLDER [SEARCH_FOLDER ...]

``xface optimize`` scores every face on one pose grid (41 x 41 by default), so a face could
win by where its boundary falls between that grid's nodes. For each search folder this reads
``summary.json`` and ``best.yaml`` and prints the seated fraction of the X-Face at the same
H/D and r_p and of the best face on the search's grid, on a finer grid (81 x 81) and on the
paper's theta grid, with the gain on each. A gain that holds on the other grids is the face's.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from xface_core.facefile import load_face
from xface_core.geometry import x_face
from xface_core.maps.acceptance import acceptance_map
from xface_core.physics import Physics

#: The grids checked: (nodes per axis, theta grid kind); the first is replaced by the search's.
CHECK_GRIDS = ((81, "symmetric"), (41, "paper"))


def check(folder: Path) -> list[str]:
    summary = json.loads((folder / "summary.json").read_text())
    family = summary["family"]
    physics = Physics(damping_ratio=summary["damping_ratio"], friction=summary["friction"])
    start = x_face(family["h_over_d"], family["r_p"])
    best = load_face(folder / "best.yaml").with_width(1.0)
    lines = [f"{folder}: {best.display_name} (criterion {summary['criterion']})"]
    grids = ((summary["grid"], summary["theta_kind"]), *CHECK_GRIDS)
    for grid, kind in grids:
        m = [
            acceptance_map(d, grid=grid, theta_kind=kind, physics=physics).M for d in (start, best)
        ]
        cells = grid * grid
        lines.append(
            f"  {grid} x {grid} ({kind}): X-Face {m[0]} ({m[0] / cells:.4f}), best {m[1]} "
            f"({m[1] / cells:.4f}), gain {m[1] / m[0] - 1:+.2%}"
        )
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", nargs="+", type=Path, help="xface optimize --out folders")
    args = parser.parse_args(argv)
    for folder in args.folders:
        if not (folder / "summary.json").is_file() or not (folder / "best.yaml").is_file():
            print(f"{folder}: no summary.json and best.yaml: not a finished xface optimize folder")
            return 2
        for line in check(folder):
            print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
