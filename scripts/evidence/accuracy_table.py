"""The accuracy table: xface against the converged Chipmunk2D engine, design by design.

    python scripts/evidence/accuracy_table.py --out docs/accuracy.md         # all, 21 x 21
    python scripts/evidence/accuracy_table.py --only "V 0.0625 1" --grid 11  # one, quick
    python scripts/evidence/accuracy_table.py --check                   # exit 1 below the bar

For every design of :data:`DESIGNS` (the paper's four sizes of each face and more, H/D from
0.0625 to 5.278, r_p from 0 to 8, two with friction, and the two custom faces of the golden
outputs, one of them with friction too) it runs
:func:`xface_core.crosscheck.crosscheck` with ``converged=True`` and writes one row: M from
xface and from the engine (sharp and rounded corners), agreement on the cells where the
engine's answer is unambiguous, the ambiguous count, false SEATED and false failures, and
then every disagreement with both final states.

The engine's runs depend only on the polygons, the physics and the engine's settings, not on
xface: they are stored in ``--cache`` (default ``.crosscheck-cache/``, keyed by all of those
and by the scene's source) so that a rerun after a change to xface only reruns xface.
``--no-cache`` reruns the engine too. The engine takes from under a minute to several
minutes per design on two cores.

The bar (``--check``): on every design at least 99.5 % agreement on the unambiguous cells
and no false SEATED.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import pickle
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

from golden_maps import lopsided_face, trapezoid_face

import xface_core as xf
from xface_core.crosscheck import compare as cc
from xface_core.crosscheck import scene

#: Custom faces by name (the golden outputs' two: scripts/evidence/golden_maps.py).
CUSTOM = {"trapezoid": trapezoid_face, "lopsided": lopsided_face}

#: Agreement (fraction of the unambiguous cells) every design must reach.
AGREEMENT_BAR = 0.995


@dataclass(frozen=True)
class Design:
    face: str
    h_over_d: float
    r_p: float
    friction: float = 0.0
    note: str = ""

    @property
    def label(self) -> str:
        mu = f", mu {self.friction:g}" if self.friction else ""
        if self.face in CUSTOM:
            return f"custom {self.face}{mu}"
        return f"{self.face} {self.h_over_d:g}, {self.r_p:g}{mu}"

    def build(self) -> xf.FaceDesign:
        if self.face in CUSTOM:
            return CUSTOM[self.face]()
        return xf.make_face(self.face, self.h_over_d, self.r_p)

    def physics(self) -> xf.Physics:
        return xf.Physics(friction=self.friction)


PAPER = ((0.0625, 1.0), (0.32988, 2.0), (1.0, 3.0), (3.0314, 5.0))

#: The designs of the table: the paper's four per face, then the extremes of H/D and r_p.
DESIGNS: tuple[Design, ...] = (
    *(Design("X", h, r, note="paper") for h, r in PAPER),
    *(Design("V", h, r, note="paper") for h, r in PAPER),
    *(Design("S", h, r, note="paper") for h, r in PAPER),
    Design("X", 0.18946, 0.0),
    Design("X", 0.57435, 0.0),
    Design("X", 5.278, 8.0),
    Design("V", 0.10882, 0.0),
    Design("V", 0.57435, 1.0),
    Design("V", 5.278, 8.0),
    Design("V", 9.1896, 4.0),
    Design("S", 0.18946, 0.0),
    Design("S", 0.5, 1.0),
    Design("S", 1.7411, 4.0),
    Design("S", 5.278, 8.0),
    Design("V", 0.32988, 2.0, friction=0.2),
    Design("X", 1.0, 3.0, friction=0.3),
    Design("S", 0.0625, 1.0, friction=0.2),
    Design("trapezoid", 0.0, 0.0, note="custom"),
    Design("trapezoid", 0.0, 0.0, friction=0.15, note="custom"),
    Design("lopsided", 0.0, 0.0, note="custom"),
)


def _cache_key(design: Design, grid: int) -> str:
    """Everything the engine's answer depends on."""
    parts = [
        repr(design.build()),
        repr(design.physics()),
        str(grid),
        repr(scene.DEFAULT_ENGINE),
        repr(scene.DEFAULT_ROUNDING),
        repr(cc.MAX_HALVINGS),
        hashlib.sha256(Path(scene.__file__).read_bytes()).hexdigest(),
        scene.pymunk.version,
    ]
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()[:20]


def engine_map(design: Design, grid: int, cache: Path | None, quiet: bool) -> cc.EngineMap:
    path = None if cache is None else cache / f"{_cache_key(design, grid)}.pkl"
    if path is not None and path.exists():
        with path.open("rb") as f:
            stored = pickle.load(f)
        assert isinstance(stored, cc.EngineMap)
        if stored.stall_changes is not None:
            return stored
        # Stored before the stall confirmation existed: add it (only the jammed cells run).
        result = cc.confirm_stalls(design.build(), stored, design.physics())
        _store(path, result)
        return result
    result = cc.engine_map(
        design.build(),
        design.physics(),
        grid=grid,
        converged=True,
        progress=None if quiet else cc.stderr_progress,
    )
    if path is not None:
        _store(path, result)
    return result


def _store(path: Path, result: cc.EngineMap) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    with tmp.open("wb") as f:
        pickle.dump(result, f)
    tmp.replace(path)


def _pct(x: float) -> str:
    return "n/a" if math.isnan(x) else f"{100 * x:.2f} %"


def _row(design: Design, r: cc.CrosscheckResult) -> str:
    mx, ms, mr = r.m_values()
    step = r.settings.step
    ok = r.agreement >= AGREEMENT_BAR and r.false_seated == 0
    return (
        f"| {design.label} | {design.note} | {mx} | {ms} / {mr} | {r.n_unambiguous} "
        f"| {_pct(r.agreement)} | {r.n_ambiguous} | {r.false_seated} | {r.false_failures} "
        f"| {step:g}{'' if r.converged else ' (not converged)'} | {r.stall_changes} "
        f"| {r.knife_edges} "
        f"| {'yes' if ok else '**no**'} |"
    )


def _disagreement_lines(design: Design, r: cc.CrosscheckResult) -> list[str]:
    out = []
    for d in r.disagreements:
        e = d.engine
        out.append(
            f"- {design.label}: x0 = {d.x0:+.3f} D, theta0 = {d.theta0:+.4f} rad: {d.kind}; "
            f"xface {d.xface.outcome.name} ({d.xface.phi_b:+.3f}, {d.xface.phi_m:+.3f}, "
            f"{d.xface.y_m:.3f}), engine {e.outcome.name} ({e.phi_b:+.3f}, {e.phi_m:+.3f}, "
            f"{e.y_m:.3f}) {e.reason}"
        )
    return out


def markdown(rows: list[tuple[Design, cc.CrosscheckResult]], grid: int, command: str) -> str:
    lines = [
        "# Accuracy: xface against the converged engine",
        "",
        (
            f"Generated by `{command}`. {grid} x {grid} cells per design (x0 from -D to D, "
            "theta0 from -pi/2 to pi/2), each run in xface and in Chipmunk2D with sharp and "
            "rounded corners, the engine's step halved until its map stopped changing "
            "(`docs/crosscheck.md`). Damping ratio 1."
        ),
        "",
        (
            "M: SEATED cells (xface; engine sharp / rounded). Jams that crept: jammed engine cells "
            "whose seating changed when run again at 1/100 of the stall speed (a creep, not a "
            "jam; the slower run is the one compared). Knife edges: disagreeing cells whose "
            "sharp engine answer flips within 0.002 D of x0 (counted ambiguous). Agreement: "
            "on SEATED or not, over "
            "the cells where the engine's answer is unambiguous. Bar: at least "
            f"{100 * AGREEMENT_BAR:g} % and no false SEATED."
        ),
        "",
        (
            "| design (face H/D, r_p) | | M xface | M engine | unambiguous | agreement "
            "| ambiguous | false SEATED | false failures | engine step (D) | jams that crept "
            "| knife edges | bar |"
        ),
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    lines += [_row(d, r) for d, r in rows]
    dis = [line for d, r in rows for line in _disagreement_lines(d, r)]
    lines += ["", "## Disagreements", "", "Final states: (phi_B, phi_M in rad, y_M in D).", ""]
    lines += dis if dis else ["None."]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grid", type=int, default=21)
    ap.add_argument(
        "--only", nargs="*", default=None, help='designs as "V 0.0625 1 [mu]" or "trapezoid [mu]"'
    )
    ap.add_argument("--cache", type=Path, default=Path(".crosscheck-cache"))
    ap.add_argument("--no-cache", action="store_true")
    ap.add_argument(
        "--cached-only", action="store_true", help="skip designs whose engine runs are not stored"
    )
    ap.add_argument("--out", type=Path, default=None, help="markdown file (default: stdout)")
    ap.add_argument("--json", type=Path, default=None, help="per-design summary as JSON")
    ap.add_argument("--check", action="store_true", help="exit 1 when a design misses the bar")
    ap.add_argument("--quiet", action="store_true")
    args = ap.parse_args(argv)
    designs = list(DESIGNS)
    if args.only:
        designs = []
        for spec in args.only:
            f, *rest = spec.split()
            if f in CUSTOM:
                designs.append(Design(f, 0.0, 0.0, float(rest[0]) if rest else 0.0))
                continue
            h, r, *mu = rest
            designs.append(Design(f, float(h), float(r), float(mu[0]) if mu else 0.0))
    rows = []
    for d in designs:
        t0 = time.monotonic()
        if args.cached_only and not (args.cache / f"{_cache_key(d, args.grid)}.pkl").exists():
            continue
        em = engine_map(d, args.grid, None if args.no_cache else args.cache, args.quiet)
        r = cc.drop_knife_edges(cc.compare_with_engine(d.build(), em, d.physics()))
        rows.append((d, r))
        if not args.quiet:
            print(
                f"{d.label}: agreement {_pct(r.agreement)}, false SEATED {r.false_seated}, "
                f"false failures {r.false_failures}, ambiguous {r.n_ambiguous} "
                f"({time.monotonic() - t0:.0f} s)",
                file=sys.stderr,
                flush=True,
            )
    command = "python scripts/evidence/accuracy_table.py" + (
        f" --grid {args.grid}" if args.grid != 21 else ""
    )
    text = markdown(rows, args.grid, command)
    if args.out is None:
        print(text, end="")
    else:
        args.out.write_text(text)
    if args.json is not None:
        args.json.write_text(
            json.dumps(
                [
                    {
                        **asdict(d),
                        "agreement": r.agreement,
                        "n_unambiguous": r.n_unambiguous,
                        "n_ambiguous": r.n_ambiguous,
                        "false_seated": r.false_seated,
                        "false_failures": r.false_failures,
                        "m": r.m_values(),
                        "engine_step": r.settings.step,
                        "converged": r.converged,
                    }
                    for d, r in rows
                ],
                indent=1,
            )
        )
    failing = [d.label for d, r in rows if r.agreement < AGREEMENT_BAR or r.false_seated]
    if failing:
        print("below the bar: " + "; ".join(failing), file=sys.stderr)
    return 1 if (args.check and failing) else 0


if __name__ == "__main__":
    sys.exit(main())
