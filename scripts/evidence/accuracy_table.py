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
then every disagreement with both final states. A cell where xface stops and the engine
seats is first solved a third way (:func:`drop_rigid_jams`): when the rigid quasi-static
Coulomb problem has no way through xface's stop either (a wedge, or a pole of the drive
force), the cell is a *rigid jam*, listed with its verdict and counted ambiguous.

The engine's runs depend only on the polygons, the physics and the engine's settings, not on
xface: they are kept in ``--store`` (default ``scripts/evidence/engine_maps/``, committed: one
``.npz`` of plain arrays per design, :mod:`xface_core.crosscheck.store`, named by the design
and a key hashing all of those and the scene's source), with the extra runs of the knife-edge
checks, so that a rerun after a change to xface only reruns xface (seconds for the whole
table). A design without a file runs the engine and writes one; ``--no-store`` reruns the
engine and writes nothing. The engine takes from a minute to hours per design on two cores.
A change to the scene's code or settings, or another pymunk, changes every key: the kept runs
are then used as they are, with a warning naming what they were made with, unless
``--rerun-stale`` runs the engine again. While a design's engine map runs, each engine run is
journaled as it ends (``<design>.<grid>.journal.jsonl`` beside the kept maps,
:mod:`xface_core.crosscheck.journal`): a map stopped part way resumes from there when run
again, and the journal goes once the map is kept.

With ``--out`` an existing file keeps everything after the line :data:`KEEP_MARKER` (the
hand-written discussion of the disagreements); only the text above it is generated.

The bar (``--check``): on every design at least 99.5 % agreement on the unambiguous cells
and no false SEATED.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import json
import math
import sys
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

from golden_maps import lopsided_face, trapezoid_face
from two_contact_coulomb import RigidStop, State, rigid_stop

import xface_core as xf
from xface_core.crosscheck import compare as cc
from xface_core.crosscheck import scene, store
from xface_core.crosscheck.journal import RunJournal
from xface_core.errors import XfaceError

#: Custom faces by name (the golden outputs' two: scripts/evidence/golden_maps.py).
CUSTOM = {"trapezoid": trapezoid_face, "lopsided": lopsided_face}

#: Agreement (fraction of the unambiguous cells) every design must reach.
AGREEMENT_BAR = 0.995
#: Where the engine's runs are kept (committed evidence).
STORE = Path(__file__).resolve().parent / "engine_maps"
#: The line after which an existing ``--out`` file is kept as it is.
KEEP_MARKER = (
    "<!-- Generated above by scripts/evidence/accuracy_table.py; kept as written below. -->"
)


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
    """Everything the engine's answer depends on (of the physics, what the scene takes:
    xface's solver settings are not the engine's)."""
    physics = design.physics()
    parts = [
        repr(design.build()),
        repr((physics.damping_ratio, physics.friction)),
        str(grid),
        repr(scene.DEFAULT_ENGINE),
        repr(scene.DEFAULT_ROUNDING),
        repr(cc.MAX_HALVINGS),
        _scene_sha256(),
        scene.pymunk.version,
    ]
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()[:20]


def _scene_sha256() -> str:
    """The engine scene's source, hashed: the runs depend on its code."""
    return hashlib.sha256(Path(scene.__file__).read_bytes()).hexdigest()


def _slug(design: Design) -> str:
    return "".join(c if c.isalnum() or c in ".-" else "-" for c in design.label.replace(", ", "_"))


def store_path(store_dir: Path, design: Design, grid: int) -> Path:
    """The design's file in ``store_dir`` for today's key: its label made a file name, and
    the key."""
    return store_dir / f"{_slug(design)}.{_cache_key(design, grid)}.npz"


def journal_path(store_dir: Path, design: Design, grid: int) -> Path:
    """Where the design's engine runs are journaled while its map runs
    (:mod:`xface_core.crosscheck.journal`): an interrupted map resumes from there, and the
    file goes once the map is stored."""
    return store_dir / f"{_slug(design)}.{grid}.journal.jsonl"


def stored_path(store_dir: Path, design: Design, grid: int) -> Path | None:
    """The design's file in ``store_dir`` whatever its key (today's if there is one), or
    None."""
    today = store_path(store_dir, design, grid)
    if today.exists():
        return today
    found = sorted(store_dir.glob(f"{_slug(design)}.*.npz"))
    found = [p for p in found if p.name.count(".") == today.name.count(".")]
    return found[0] if found else None


def provenance() -> dict[str, str]:
    """What the engine's runs were made with, in words (the key hashes the same)."""
    return {
        "pymunk": str(scene.pymunk.version),
        "scene_sha256": _scene_sha256(),
    }


def engine_map(
    design: Design,
    grid: int,
    store_dir: Path | None,
    quiet: bool,
    rerun_stale: bool = False,
    workers: int | None = None,
) -> tuple[store.StoredEvidence, Path | None]:
    """The design's converged engine map and its file: from ``store_dir`` when a file is
    there (made with other engine code or settings than today's, it is used as it is, with
    a warning, unless ``rerun_stale``), else run (minutes to hours) and, with a
    ``store_dir``, written there."""
    key = _cache_key(design, grid)
    path = None if store_dir is None else stored_path(store_dir, design, grid)
    stored = None if path is None else store.load(path)
    if stored is not None and path is not None and stored.key != key:
        if rerun_stale:
            stored = None
        else:
            print(
                f"{design.label}: {path.name} was made with other engine code or settings "
                f"({dict(stored.provenance)}); used as stored (--rerun-stale runs it again)",
                file=sys.stderr,
            )
    if stored is not None and path is not None:
        if stored.engine.stall_changes is not None:
            return stored, path
        # Stored before the stall confirmation existed: add it (only the jammed cells run).
        confirmed = cc.confirm_stalls(design.build(), stored.engine, design.physics())
        stored = replace(stored, engine=confirmed)
        store.save(path, stored)
        return stored, path
    with contextlib.ExitStack() as stack:
        runs = None
        if store_dir is not None:
            runs = stack.enter_context(RunJournal(journal_path(store_dir, design, grid), key))
            if runs.replaced_other:
                print(
                    f"{design.label}: {runs.path.name} was made with other engine code or "
                    "settings; it is replaced as the engine runs",
                    file=sys.stderr,
                )
            elif len(runs) and not quiet:
                print(f"{design.label}: resuming with {len(runs)} runs kept", file=sys.stderr)
        result = cc.engine_map(
            design.build(),
            design.physics(),
            grid=grid,
            converged=True,
            progress=None if quiet else cc.stderr_progress,
            journal=runs,
            workers=workers,
        )
    evidence = store.StoredEvidence(key, design.label, result, provenance=provenance())
    path = None if store_dir is None else store_path(store_dir, design, grid)
    if path is not None and store_dir is not None:
        store.save(path, evidence)
        journal_path(store_dir, design, grid).unlink(missing_ok=True)
    return evidence, path


def compare(
    design: Design, evidence: store.StoredEvidence, path: Path | None
) -> cc.CrosscheckResult:
    """xface against the stored map, knife edges dropped; the knife-edge runs not yet kept
    are run and (with a ``path``) added to the design's file."""
    r = cc.compare_with_engine(design.build(), evidence.engine, design.physics())
    missing = [c for c in cc.knife_edge_cells(r) if c not in evidence.probes]
    probes = dict(evidence.probes)
    if missing:
        tasks = [(x0, theta0, r.settings) for x0, theta0 in missing]
        probes.update(zip(missing, cc.run_engine(r.design, r.physics, tasks), strict=True))
        if path is not None:
            store.save(path, replace(evidence, probes=probes))
    return cc.drop_knife_edges(r, known=probes)


#: A disagreement whose xface stop the rigid model shares, with the verdict.
RigidJam = tuple[cc.Disagreement, RigidStop]


def drop_rigid_jams(
    design: Design, r: cc.CrosscheckResult
) -> tuple[cc.CrosscheckResult, tuple[RigidJam, ...]]:
    """The comparison with every false failure whose stop the rigid model shares marked
    ambiguous, and those cells with their verdicts.

    At each cell where xface stops and the engine seats, the quasi-static Coulomb problem is
    solved on its own at xface's final state (``two_contact_coulomb.rigid_stop``: nothing of
    xface's contact mechanics): a wedge there (no admissible motion) or a pole of the drive
    force (it grows as 1 / distance up to the stop, and no motion is admissible past it)
    means the rigid model has no way through, and the engine's seat is its compliance and
    iterated friction sliding where the model cannot. The engine is then no reference for
    the cell. A false SEATED is never dropped.
    """
    physics = design.physics()
    face = design.build()
    kept: list[cc.Disagreement] = []
    jams: list[RigidJam] = []
    ambiguous = r.ambiguous.copy()
    for d in r.disagreements:
        verdict = None
        if d.kind == "false failure":
            stop = State(d.xface.phi_b, d.xface.phi_m, d.x0, d.xface.y_m)
            verdict = rigid_stop(face, stop, physics.friction, physics.damping_ratio)
        if verdict is not None and verdict.kind:
            jams.append((d, verdict))
            ambiguous[d.index] = True
        else:
            kept.append(d)
    return replace(r, ambiguous=ambiguous, disagreements=tuple(kept)), tuple(jams)


def _pct(x: float) -> str:
    return "n/a" if math.isnan(x) else f"{100 * x:.2f} %"


def _row(design: Design, r: cc.CrosscheckResult, jams: int) -> str:
    mx, ms, mr = r.m_values()
    step = r.settings.step
    ok = r.agreement >= AGREEMENT_BAR and r.false_seated == 0
    return (
        f"| {design.label} | {design.note} | {mx} | {ms} / {mr} | {r.n_unambiguous} "
        f"| {_pct(r.agreement)} | {r.n_ambiguous} | {r.false_seated} | {r.false_failures} "
        f"| {step:g}{'' if r.converged else ' (not converged)'} | {r.stall_changes} "
        f"| {r.knife_edges} | {jams} "
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


def _rigid_jam_lines(design: Design, jams: tuple[RigidJam, ...]) -> list[str]:
    out = []
    for d, verdict in jams:
        e = d.engine
        out.append(
            f"- {design.label}: x0 = {d.x0:+.3f} D, theta0 = {d.theta0:+.4f} rad: "
            f"{verdict.kind} ({verdict.detail}); xface ({d.xface.phi_b:+.3f}, "
            f"{d.xface.phi_m:+.3f}, {d.xface.y_m:.3f}), engine {e.outcome.name} "
            f"({e.phi_b:+.3f}, {e.phi_m:+.3f}, {e.y_m:.3f})"
        )
    return out


Row = tuple[Design, cc.CrosscheckResult, tuple[RigidJam, ...]]


def markdown(rows: list[Row], grid: int, command: str) -> str:
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
            "sharp engine answer flips within 0.002 D of x0 (counted ambiguous). Rigid jams: "
            "cells where xface stops and the engine seats, and the quasi-static Coulomb "
            "problem solved on its own at xface's stop (`scripts/evidence/two_contact_coulomb.py`) "
            "has no motion there either: a wedge, or a drive force that grows without bound "
            "up to the stop with no motion past it (counted ambiguous: the engine's "
            "compliance slides where the rigid model cannot). Agreement: "
            "on SEATED or not, over "
            "the cells where the engine's answer is unambiguous. Bar: at least "
            f"{100 * AGREEMENT_BAR:g} % and no false SEATED."
        ),
        "",
        (
            "| design (face H/D, r_p) | | M xface | M engine | unambiguous | agreement "
            "| ambiguous | false SEATED | false failures | engine step (D) | jams that crept "
            "| knife edges | rigid jams | bar |"
        ),
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    lines += [_row(d, r, len(j)) for d, r, j in rows]
    dis = [line for d, r, _ in rows for line in _disagreement_lines(d, r)]
    lines += ["", "## Disagreements", "", "Final states: (phi_B, phi_M in rad, y_M in D).", ""]
    lines += dis if dis else ["None."]
    jams = [line for d, _, j in rows for line in _rigid_jam_lines(d, j)]
    lines += ["", "## Rigid jams", "", "Final states as above; the engine's is a seat.", ""]
    lines += jams if jams else ["None."]
    lines += ["", KEEP_MARKER]
    return "\n".join(lines) + "\n"


def kept_text(path: Path) -> str:
    """What follows :data:`KEEP_MARKER` in ``path`` (nothing if the file or the line is
    missing)."""
    if not path.exists():
        return ""
    _, marker, after = path.read_text().partition(KEEP_MARKER + "\n")
    return after if marker else ""


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grid", type=int, default=21)
    ap.add_argument(
        "--only", nargs="*", default=None, help='designs as "V 0.0625 1 [mu]" or "trapezoid [mu]"'
    )
    ap.add_argument(
        "--store", type=Path, default=STORE, help="where the engine's runs are kept (.npz)"
    )
    ap.add_argument("--no-store", action="store_true", help="run the engine, keep nothing")
    ap.add_argument(
        "--stored-only", action="store_true", help="skip designs whose engine runs are not kept"
    )
    ap.add_argument(
        "--rerun-stale",
        action="store_true",
        help="run the engine again where the kept runs were made with other engine code",
    )
    ap.add_argument("--out", type=Path, default=None, help="markdown file (default: stdout)")
    ap.add_argument("--json", type=Path, default=None, help="per-design summary as JSON")
    ap.add_argument("--check", action="store_true", help="exit 1 when a design misses the bar")
    ap.add_argument("--quiet", action="store_true")
    ap.add_argument(
        "--workers",
        type=int,
        default=None,
        help="engine processes where the engine runs (default: one per CPU)",
    )
    args = ap.parse_args(argv)
    try:
        return _run(args)
    except (XfaceError, OSError) as exc:
        # A hostile or damaged kept map or journal, an unwritable --out: said, not a traceback.
        print(f"accuracy_table: error: {exc}", file=sys.stderr)
        return 2


def _run(args: argparse.Namespace) -> int:
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
        store_dir = None if args.no_store else args.store
        if args.stored_only and (store_dir is None or stored_path(store_dir, d, args.grid) is None):
            continue
        evidence, path = engine_map(
            d, args.grid, store_dir, args.quiet, args.rerun_stale, args.workers
        )
        r, jams = drop_rigid_jams(d, compare(d, evidence, path))
        rows.append((d, r, jams))
        if not args.quiet:
            print(
                f"{d.label}: agreement {_pct(r.agreement)}, false SEATED {r.false_seated}, "
                f"false failures {r.false_failures}, ambiguous {r.n_ambiguous}, "
                f"rigid jams {len(jams)} "
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
        args.out.write_text(text + kept_text(args.out))
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
                        "rigid_jams": len(jams),
                    }
                    for d, r, jams in rows
                ],
                indent=1,
            )
        )
    failing = [d.label for d, r, _ in rows if r.agreement < AGREEMENT_BAR or r.false_seated]
    if failing:
        print("below the bar: " + "; ".join(failing), file=sys.stderr)
    return 1 if (args.check and failing) else 0


if __name__ == "__main__":
    sys.exit(main())
