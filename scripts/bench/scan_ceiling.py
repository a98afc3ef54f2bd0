#!/usr/bin/env python3
"""The ceiling of any cheaper new-contact scan: the engine with an oracle that scans, per
cell, only the pairs that turn out to matter, against the same engine scanning every pair.

    python scripts/bench/scan_ceiling.py                    # HEAD: a 2-minute build, then 1 min
    python scripts/bench/scan_ceiling.py --no-turn-cap      # and no cap on a step's turn

Issue 37 asks 41 x 41 maps at 0.4 of 93b694f's time, and the notes found the new-contact scan
to be most of a step's cycles. Any redesign of that scan (budgets per segment, certificates,
a broad phase) can at best skip every pair that does not matter. This script measures that
best case instead of estimating it:

1. ``git archive COMMIT xface_core`` into a temporary folder, edited (:func:`apply_oracle`):
   two columns more in the pair table, "scan this pair" and "this pair mattered"; a pair
   matters when it is active in an interval, is the pair of a new-contact event, or has
   two corners crossed at a step's end (what starts the fine samples). The new-contact scan
   treats a pair not to be scanned as asleep (so do the dip search, the check at an event's
   state and the corner check, which skip sleeping pairs); every other stage is unchanged.
   ``--no-turn-cap`` also sets ``records.MAX_TURN`` to 3 rad (no cap in practice: unsafe,
   docs/notes/2026-11-30-what-bounds-the-speed-goal.md), the step count of the error
   control alone.
2. It is compiled into a numba cache of its own (no precompiled build), for this host.
3. Per design (X 0.25/2, X 1/1, V 0.5/1, S 0.5/1; every cell of the 41 x 41 grid, one
   thread, the default physics): one recording pass writes each cell's pairs that mattered;
   then, ``--rounds`` times, the whole grid scanning every pair ("every pair") and scanning
   each cell's recorded pairs only ("oracle").

``--why-awake`` adds a pass that counts, for the pairs that did not matter, the steps in which
they were awake all the same, by what kept them awake (:data:`WHY_AWAKE`).

Prints per design the pairs per cell, the best times, their ratio, and whether the outcomes
and step counts of both passes equal those of the recording pass (the oracle's set suffices
when they do). Exit 1 if a build, a run or an edit fails. ``--keep`` keeps the folder.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

#: (file under xface_core/, text found once, its replacement)
EDITS: tuple[tuple[str, str, str], ...] = (
    (
        "_engine/pairs.py",
        "PAIR_COLUMNS = @P@\n",
        "PAIR_COLUMNS = @N2@  # @O@: scan this pair (oracle), @S@: it mattered (recorded)\n",
    ),
    (
        "contact.py",
        "    out[:, :, COL_LENGTH_AFTER] = length_after[:, None]\n",
        (
            "    out[:, :, COL_LENGTH_AFTER] = length_after[:, None]\n"
            "    out[:, :, @O@] = 1.0\n    out[:, :, @S@] = 0.0\n"
        ),
    ),
    (
        "_engine/scan.py",
        "        travel = _travel(row, step.h, turn)\n        if sleep[i, 0] > travel:\n",
        (
            "        travel = _travel(row, step.h, turn)\n"
            "        if row[@O@] == 0.0:\n"
            "            sleep[i, 1] = travel\n"
            "            sleep[i, 2] = 1.0\n"
            "            continue\n"
            "        if sleep[i, 0] > travel:\n"
        ),
    ),
    (
        "_engine/scan.py",
        "(cb0, sb0, cm0, sm0, step.y_m, step.phi_b, step.phi_m))  # fmt: skip\n",
        (
            "(cb0, sb0, cm0, sm0, step.y_m, step.phi_b, step.phi_m))  # fmt: skip\n"
            "            if crossed:\n                row[@S@] = 1.0\n"
        ),
    ),
    (
        "_engine/simulate.py",
        "        if run.n_active == 0:\n            approach(",
        (
            "        for k in range(run.n_active):\n"
            "            model.pairs[work.act[k], @S@] = 1.0\n"
            "        if run.n_active == 0:\n            approach("
        ),
    ),
    (
        "_engine/segment.py",
        "    elif kind == E_CONTACT:\n",
        "    elif kind == E_CONTACT:\n        seg.held.pairs[ev.pair, @S@] = 1.0\n",
    ),
    (
        "_engine/__init__.py",
        "    simulate_many,\n    simulate_one,\n",
        "    simulate_many,\n    simulate_many_oracle,\n    simulate_one,\n",
    ),
)

NO_TURN_CAP = ("_engine/records.py", "\nMAX_TURN = 0.02\n", "\nMAX_TURN = 3.0\n")

#: ``--why-awake``, after :data:`EDITS`: six columns more (:func:`columns`). Column @M@
#: marks the pairs that mattered in the cell being run; four from @C@ count the steps in
#: which a pair that did not matter was awake (in reach, so evaluated and tested), by which
#: limit of its budget (``scan.reach_budget``'s rule, from the values at the step's start)
#: kept it awake, the distance to its edge or to its start corner (the corner test's reach,
#: for a pair that judges its meeting), and whether its vertex was outside its edge's line
#: or behind it; @T@ counts them all.
WHY_AWAKE: tuple[tuple[str, str, str], ...] = (
    ("_engine/pairs.py", "PAIR_COLUMNS = @N2@", "PAIR_COLUMNS = @N8@"),
    (
        "contact.py",
        "    out[:, :, @S@] = 0.0\n",
        "    out[:, :, @S@] = 0.0\n    out[:, :, @M@:@N8@] = 0.0\n",
    ),
    (
        "_engine/scan.py",
        "        _refresh_start(row, i, work, (cb0, sb0, cm0, sm0), x0, step.y_m)\n        g1, u1,",
        (
            "        _refresh_start(row, i, work, (cb0, sb0, cm0, sm0), x0, step.y_m)\n"
            "        if row[@M@] == 0.0:\n"
            "            gq, uq, ln = g_prev[i], u_prev[i], row[COL_EDGE_LENGTH]\n"
            "            al = (-0.25 - uq) * ln if uq < -0.25 else max(uq - 1.25, 0.0) * ln\n"
            "            to_edge, to_corner = max(abs(gq), al), math.inf\n"
            "            if tests_corner_crossing(row):\n"
            "                to_corner = max(abs(uq) * ln, abs(gq)) - 0.52 * ln\n"
            "            by_corner = 1 if to_corner < to_edge else 0\n"
            "            row[@C@ + 2 * by_corner + (1 if gq < 0.0 else 0)] += 1.0\n"
            "            row[@T@] += 1.0\n"
            "        g1, u1,"
        ),
    ),
)

#: Appended to the copy's simulate.py: the grid with a per-cell mask of pairs to scan.
ORACLE_ENTRY = '''

@njit_cached
def simulate_many_oracle(
    model: Model, opts: Options, xs: FloatArray, ts: FloatArray, ys: FloatArray,
    masks: FloatArray, record: bool,
) -> npt.NDArray[np.void]:
    """simulate over flat poses scanning, per pose k, the pairs with masks[k] = 1; with
    ``record`` every pair is scanned and masks[k] receives the pairs that mattered."""
    n = xs.shape[0]
    runs = np.zeros(n, dtype=RUN_DTYPE)
    path = np.zeros((1, 4))
    path_pairs = np.full((1, 4), -1, dtype=np.int64)
    work = new_work(model, opts)
    table = model.pairs
    for k in range(n):
        for i in range(table.shape[0]):
            table[i, @O@] = 1.0 if record else masks[k, i]
            table[i, @S@] = 0.0
        reset_work(work)
        simulate(model, opts, xs[k], ts[k], ys[k], runs[k], path, path_pairs, work)
        if record:
            for i in range(table.shape[0]):
                masks[k, i] = table[i, @S@]
    return runs
'''

#: Run in the copy: prints one JSON line per design.
DRIVER = """
import json, sys, time
import numpy as np
import xface_core as xf
from xface_core import _engine, runner
from xface_core.maps.grids import theta_grid, x0_grid
rounds, why_awake = int(sys.argv[1]), sys.argv[2] == "1"
designs = [("X 0.25/2", xf.x_face(0.25, 2.0)), ("X 1/1", xf.x_face(1.0, 1.0)),
           ("V 0.5/1", xf.v_face(0.5, 1.0)), ("S 0.5/1", xf.s_face(0.5, 1.0))]
gx, gt = np.meshgrid(x0_grid(41), theta_grid(41), indexing="ij")
xs, ts = np.ascontiguousarray(gx.ravel()), np.ascontiguousarray(gt.ravel())
opts = _engine.make_options(xf.Physics())
for name, design in designs:
    model = runner.engine_model(design)
    ys = np.ascontiguousarray(runner.start_heights(design, ts))
    n, m = xs.size, model.pairs.shape[0]
    masks = np.zeros((n, m))
    rec = _engine.simulate_many_oracle(model, opts, xs, ts, ys, masks, True)
    every = np.ones((n, m))
    t_every, t_oracle = [], []
    for _ in range(rounds):
        t = time.perf_counter()
        a = _engine.simulate_many_oracle(model, opts, xs, ts, ys, every, False)
        t_every.append(time.perf_counter() - t)
        t = time.perf_counter()
        b = _engine.simulate_many_oracle(model, opts, xs, ts, ys, masks, False)
        t_oracle.append(time.perf_counter() - t)
    same = all(
        bool((r["outcome"] == rec["outcome"]).all() and (r["steps"] == rec["steps"]).all())
        for r in (a, b)
    )
    awake = [0.0] * 5
    if why_awake:  # every pair scanned, cell by cell, counting the awake ones not kept
        table = model.pairs
        table[:, @C@:@N8@] = 0.0
        for k in range(n):
            table[:, @M@] = masks[k]
            one = slice(k, k + 1)
            _engine.simulate_many_oracle(model, opts, xs[one], ts[one], ys[one], every[one], False)
        awake = table[:, @C@:@N8@].sum(0).tolist()
    print(json.dumps({"design": name, "pairs": m, "kept_mean": float(masks.sum(1).mean()),
                      "kept_max": int(masks.sum(1).max()), "every_ms": min(t_every) * 1e3,
                      "oracle_ms": min(t_oracle) * 1e3, "steps": int(rec["steps"].sum()),
                      "same": same, "awake": awake}))
"""


def columns(tree: Path) -> dict[str, str]:
    """The copy's new pair-table columns, after its own ``PAIR_COLUMNS`` = P: the oracle's
    mask (@O@ = P), what mattered (@S@), and for ``--why-awake`` the mask of what mattered in
    the cell being run (@M@), four counters from @C@ and their total (@T@); the widths @N2@
    and @N8@. ValueError when pairs.py does not say P."""
    found = re.search(
        r"^PAIR_COLUMNS = (\d+)$", (tree / "xface_core/_engine/pairs.py").read_text(), re.M
    )
    if found is None:
        raise ValueError("_engine/pairs.py: no PAIR_COLUMNS = <n> line")
    p = int(found.group(1))
    offsets = {"@P@": 0, "@O@": 0, "@S@": 1, "@M@": 2, "@C@": 3, "@T@": 7, "@N2@": 2, "@N8@": 8}
    return {key: str(p + offset) for key, offset in offsets.items()}


def with_columns(text: str, cols: dict[str, str]) -> str:
    """``text`` with the placeholders of :func:`columns` filled in."""
    for key, value in cols.items():
        text = text.replace(key, value)
    return text


def apply_oracle(
    tree: Path, *, no_turn_cap: bool = False, why_awake: bool = False
) -> dict[str, str]:
    """Edit the copy of ``xface_core`` in ``tree`` (its parent folder) as described above, and
    return the new columns (:func:`columns`, read before the edits widen the table) for the
    driver; ValueError naming the edit whose text is not found exactly once."""
    cols = columns(tree)
    edits = EDITS + ((NO_TURN_CAP,) if no_turn_cap else ()) + (WHY_AWAKE if why_awake else ())
    for name, old_text, new_text in edits:
        old, new = with_columns(old_text, cols), with_columns(new_text, cols)
        path = tree / "xface_core" / name
        text = path.read_text()
        if text.count(old) != 1:
            raise ValueError(f"{name}: the text to edit is found {text.count(old)} times: {old!r}")
        path.write_text(text.replace(old, new))
    simulate = tree / "xface_core" / "_engine" / "simulate.py"
    simulate.write_text(simulate.read_text() + with_columns(ORACLE_ENTRY, cols))
    return cols


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--commit", default="HEAD", help="the engine to measure (default HEAD)")
    parser.add_argument("--rounds", type=int, default=5, help="timed passes per variant")
    parser.add_argument("--no-turn-cap", action="store_true", help="also lift MAX_TURN")
    parser.add_argument(
        "--why-awake",
        action="store_true",
        help="also count why the pairs that did not matter were awake (a slower pass)",
    )
    parser.add_argument("--keep", action="store_true", help="keep the temporary folder")
    args = parser.parse_args()
    if args.rounds < 1:
        parser.error("--rounds must be at least 1")
    folder = Path(tempfile.mkdtemp(prefix="scan_ceiling."))
    try:
        archive = subprocess.run(
            ["git", "-C", str(ROOT), "archive", args.commit, "xface_core"],
            capture_output=True,
            check=False,
        )
        if archive.returncode != 0:
            print(f"scan_ceiling: git archive {args.commit}: {archive.stderr.decode().strip()}")
            return 1
        subprocess.run(["tar", "-x", "-C", str(folder)], input=archive.stdout, check=True)
        try:
            cols = apply_oracle(folder, no_turn_cap=args.no_turn_cap, why_awake=args.why_awake)
        except ValueError as exc:
            print(f"scan_ceiling: {exc}")
            return 1
        driver = with_columns(DRIVER, cols)
        (folder / "empty").mkdir()
        env = {
            "PATH": "/usr/bin:/bin",
            "HOME": str(folder),
            "PYTHONPATH": str(folder),
            "XFACE_PRECOMPILED_DIR": str(folder / "empty"),
            "NUMBA_CACHE_DIR": str(folder / "numba"),
        }
        done = subprocess.run(
            [sys.executable, "-c", driver, str(args.rounds), "1" if args.why_awake else "0"],
            env=env,
            cwd=folder,
            capture_output=True,
            text=True,
            check=False,
        )
        if done.returncode != 0:
            print(f"scan_ceiling: the run failed:\n{done.stderr[-3000:]}")
            return 1
        rows = [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]
    finally:
        if args.keep:
            print(f"scan_ceiling: kept {folder}")
        else:
            shutil.rmtree(folder, ignore_errors=True)
    cap = "no turn cap (MAX_TURN 3 rad)" if args.no_turn_cap else "the turn cap as committed"
    print(f"Scan ceiling at {args.commit}, {cap}; best of {args.rounds}, 41 x 41, one thread.\n")
    print("| design | pairs | scanned per cell (mean, max) | every pair (ms) | oracle (ms) "
          "| oracle / every | steps | answers as recorded |")  # fmt: skip
    print("|---|---:|---:|---:|---:|---:|---:|---|")
    for r in rows:
        print(
            f"| {r['design']} | {r['pairs']} | {r['kept_mean']:.2f}, {r['kept_max']} "
            f"| {r['every_ms']:.2f} | {r['oracle_ms']:.2f} "
            f"| {r['oracle_ms'] / r['every_ms']:.3f} | {r['steps']} "
            f"| {'yes' if r['same'] else 'NO'} |"
        )
    if args.why_awake:
        print(
            "\nSteps in which a pair that did not matter was awake, by what kept it awake "
            "(the nearer of its edge and its start corner, at the step's start) and where its "
            "vertex was:\n"
        )
        print(
            "| design | per step | edge, outside | edge, behind "
            "| corner, outside | corner, behind |"
        )
        print("|---|---:|---:|---:|---:|---:|")
        for r in rows:
            out_e, behind_e, out_c, behind_c, total = r["awake"]
            shares = " | ".join(
                f"{v / max(total, 1.0):.2f}" for v in (out_e, behind_e, out_c, behind_c)
            )
            print(f"| {r['design']} | {total / max(r['steps'], 1):.1f} | {shares} |")
    return 0 if rows else 1


if __name__ == "__main__":
    sys.exit(main())
