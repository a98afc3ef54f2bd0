"""Design search: the best H/D and r_p of one face in a box, by a criterion the user picks.

The search is a study (:func:`~xface_core.study.run.run_study`) in stages. First a coarse grid
over the box: H/D geometric (like the paper's axis, a constant ratio between neighbours),
r_p evenly spaced, every node rounded to five significant digits (so the default box and
11 steps give exactly the paper's 11 x 11 table). Then ``refine`` rounds, each a
``refine_steps`` x ``refine_steps`` grid spanning the neighbours of the best design so far
(one step of the last grid either side, clipped to the box): a grid search that halves its
step each round, which finds a narrow optimum between coarse nodes but can miss a better
peak elsewhere that the coarse grid did not see.

Criteria (larger is better): ``"M"``, the number of SEATED poses; ``"guaranteed"``, the
cells of the largest all-SEATED rectangle; ``"centred"``, the cells of the largest one
centred on the aligned pose; ``"seat_probability"``, the mean seat probability over the
grid under a pose noise (:mod:`xface_core.study.noise`; every design sees the same draws).
Ties go to the smaller H/D, then the smaller r_p (the first in the table's row-major
order). Face files are fixed designs with nothing to search: :func:`rank_face_files` runs
each once and ranks them by the same criteria.
"""

from __future__ import annotations

import math
import os
import tempfile
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from xface_core.errors import XfaceValueError
from xface_core.maps.grids import PAPER_GRID_SIZE, PAPER_H_OVER_D, PAPER_R_P, ThetaGridKind
from xface_core.physics import DEFAULT_SETTINGS, SolverSettings

from .executors import ClientLike
from .noise import PoseNoise
from .run import StudyProgress, read_study, run_study
from .space import DesignPoint, DesignSpace, FaceFamily, FileFace

__all__ = [
    "CRITERIA",
    "Criterion",
    "DesignSearch",
    "box_nodes",
    "rank_face_files",
    "search_designs",
]

Criterion = Literal["M", "guaranteed", "centred", "seat_probability"]

#: The table column each criterion ranks by.
CRITERIA: dict[str, str] = {
    "M": "M",
    "guaranteed": "guaranteed_cells",
    "centred": "centred_cells",
    "seat_probability": "seat_probability",
}

#: The paper's box (Tables II-IV): H/D from 1/16 to 16, r_p from 0 to 10 D.
PAPER_BOX_H_OVER_D = (PAPER_H_OVER_D[0], PAPER_H_OVER_D[-1])
PAPER_BOX_R_P = (PAPER_R_P[0], PAPER_R_P[-1])

#: Limits of the search's grids (nodes per axis) and of its refinement rounds: each round
#: halves the step, and after 8 the step is below the five significant digits kept.
MAX_STEPS = 101
MAX_REFINE_ROUNDS = 8


def _rounded(v: float) -> float:
    """``v`` to five significant digits, as the paper prints its H/D values."""
    return float(f"{v:.5g}")


def box_nodes(lo: float, hi: float, steps: int, *, geometric: bool) -> tuple[float, ...]:
    """``steps`` nodes from ``lo`` to ``hi`` (both included), geometric or evenly spaced,
    rounded to five significant digits.

    Examples
    --------
    >>> box_nodes(0.0625, 16.0, 11, geometric=True) == PAPER_H_OVER_D
    True
    >>> box_nodes(0.0, 10.0, 11, geometric=False) == PAPER_R_P
    True
    """
    if geometric:
        exps = np.linspace(math.log(lo), math.log(hi), steps)
        values = [lo, *(math.exp(e) for e in exps[1:-1]), hi]
    else:
        values = [lo + (hi - lo) * k / (steps - 1) for k in range(steps)]
    nodes = tuple(dict.fromkeys(_rounded(v) for v in values))  # rounding may merge nodes
    if len(nodes) < 2:
        raise XfaceValueError(f"the box [{lo:g}, {hi:g}] is narrower than five digits resolve")
    return nodes


@dataclass(frozen=True)
class DesignSearch:
    """What a search found.

    Attributes
    ----------
    face, criterion : str
    h_over_d, r_p : tuple of float
        The coarse grid's axes.
    coarse : (len(h_over_d), len(r_p)) array
        The criterion on the coarse grid (rows H/D, columns r_p), for the heat map: integers,
        or floats for the seat probability.
    ranked : list of dict
        Every design the search simulated (its study-table row), best first.
    coarse_best : dict
        The best row of the coarse grid alone.
    rounds : int
        Refinement rounds done.
    """

    face: str
    criterion: str
    h_over_d: tuple[float, ...]
    r_p: tuple[float, ...]
    coarse: npt.NDArray[Any]
    ranked: list[dict[str, Any]]
    coarse_best: dict[str, Any]
    rounds: int

    @property
    def best(self) -> dict[str, Any]:
        """The best design found (its study-table row)."""
        return self.ranked[0]


def _rank(rows: Sequence[dict[str, Any]], column: str) -> list[dict[str, Any]]:
    return sorted(rows, key=lambda r: (-r[column], r["h_over_d"], r["r_p"]))


def _check(criterion: str, steps: int, refine: int, refine_steps: int, box: Any) -> None:
    if criterion not in CRITERIA:
        raise XfaceValueError(f"criterion must be one of {', '.join(CRITERIA)}, got {criterion!r}")
    if not 2 <= steps <= MAX_STEPS:
        raise XfaceValueError(f"steps must be in [2, {MAX_STEPS}], got {steps}")
    if not 0 <= refine <= MAX_REFINE_ROUNDS:
        raise XfaceValueError(f"refine must be in [0, {MAX_REFINE_ROUNDS}], got {refine}")
    if not 3 <= refine_steps <= 21 or refine_steps % 2 == 0:
        raise XfaceValueError(f"refine steps must be odd, in [3, 21], got {refine_steps}")
    for name, (lo, hi) in box.items():
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise XfaceValueError(f"the {name} box must be two finite values lo < hi")


def _study_rows(space: DesignSpace, path: Path, **run: Any) -> list[dict[str, Any]]:
    """The table rows of ``space``'s designs, run (or resumed) in the study at ``path``."""
    run_study(space, path, **run)
    wanted = set(space.points())
    table = read_study(path).to_pylist()
    return [r for r in table if DesignPoint(*(r[k] for k in DesignPoint._fields)) in wanted]


def rank_face_files(
    files: Sequence[FileFace],
    *,
    criterion: str = "M",
    friction: float = 0.0,
    damping_ratio: float = 1.0,
    out: str | os.PathLike[str] | None = None,
    **run: Any,
) -> list[dict[str, Any]]:
    """The study-table rows of the face files ``files`` (fixed designs: nothing to search)
    at one friction and damping ratio, best first by ``criterion`` (ties by name, then
    digest). ``out`` keeps the rows (the same table a search may share, resumable); ``run``
    takes :func:`~xface_core.study.run.run_study`'s other keywords (grid, noise, ...).
    """
    if criterion not in CRITERIA:
        raise XfaceValueError(f"criterion must be one of {', '.join(CRITERIA)}, got {criterion!r}")
    if criterion == "seat_probability" and run.get("noise") is None:
        raise XfaceValueError("the seat_probability criterion needs a pose noise (sigma_x, ...)")
    space = DesignSpace(
        faces=(),
        h_over_d=(),
        r_p=(),
        friction=(friction,),
        damping_ratio=(damping_ratio,),
        face_files=tuple(files),
    )
    with tempfile.TemporaryDirectory(prefix="xface-design-") as tmp:
        path = Path(tmp) / "files.parquet" if out is None else Path(out)
        rows = _study_rows(space, path, **run)
    column = CRITERIA[criterion]
    return sorted(rows, key=lambda r: (-r[column], r["face"], r["face_digest"]))


def search_designs(
    face: str = "X",
    *,
    families: Mapping[str, FaceFamily] | None = None,
    h_over_d: tuple[float, float] = PAPER_BOX_H_OVER_D,
    r_p: tuple[float, float] = PAPER_BOX_R_P,
    steps: int = 11,
    refine: int = 1,
    refine_steps: int = 5,
    criterion: str = "M",
    friction: float = 0.0,
    damping_ratio: float = 1.0,
    grid: int = PAPER_GRID_SIZE,
    theta_kind: ThetaGridKind = "symmetric",
    settings: SolverSettings = DEFAULT_SETTINGS,
    noise: PoseNoise | None = None,
    out: str | os.PathLike[str] | None = None,
    executor: Executor | ClientLike | None = None,
    workers: int | None = None,
    progress: Callable[[StudyProgress], None] | None = None,
    allow_version_mix: bool = False,
) -> DesignSearch:
    """The best design of ``face`` (X, V, S or a name in ``families``) in the box
    ``h_over_d`` x ``r_p`` for one friction and damping ratio, by ``criterion``.

    ``noise`` adds the mean seat probability (required by that criterion). ``out`` keeps
    the study table (and makes the search resumable); by default it lives in
    a temporary folder. ``executor``, ``workers``, ``progress`` and ``allow_version_mix`` as for
    :func:`~xface_core.study.run.run_study`.

    Examples
    --------
    >>> s = search_designs("X", h_over_d=(0.25, 1.0), r_p=(0.0, 2.0), steps=3, refine=0, grid=7)
    >>> s.coarse.shape, s.best["M"] == int(s.coarse.max())
    ((3, 3), True)
    """
    _check(criterion, steps, refine, refine_steps, {"H/D": h_over_d, "r_p": r_p})
    if criterion == "seat_probability" and noise is None:
        raise XfaceValueError("the seat_probability criterion needs a pose noise (sigma_x, ...)")
    face = face if families and face in families else face.upper()
    column = CRITERIA[criterion]
    with tempfile.TemporaryDirectory(prefix="xface-design-") as tmp:
        path = Path(tmp) / "search.parquet" if out is None else Path(out)

        def stage(hs: Sequence[float], rps: Sequence[float]) -> list[dict[str, Any]]:
            space = DesignSpace(
                faces=(face,),
                h_over_d=hs,
                r_p=rps,
                friction=(friction,),
                damping_ratio=(damping_ratio,),
                families=dict(families or {}),
            )
            return _study_rows(
                space,
                path,
                grid=grid,
                theta_kind=theta_kind,
                settings=settings,
                noise=noise,
                executor=executor,
                workers=workers,
                progress=progress,
                allow_version_mix=allow_version_mix,
            )

        hs = box_nodes(*h_over_d, steps, geometric=True)
        rps = box_nodes(*r_p, steps, geometric=False)
        coarse_rows = stage(hs, rps)
        seen = {(r["h_over_d"], r["r_p"]): r for r in coarse_rows}
        h_ratio, rp_step = (h_over_d[1] / h_over_d[0]) ** (1 / (steps - 1)), rps[1] - rps[0]
        for _ in range(refine):
            best = _rank(list(seen.values()), column)[0]
            h_lo = max(h_over_d[0], best["h_over_d"] / h_ratio)
            h_hi = min(h_over_d[1], best["h_over_d"] * h_ratio)
            rp_lo, rp_hi = max(r_p[0], best["r_p"] - rp_step), min(r_p[1], best["r_p"] + rp_step)
            fine_h = box_nodes(h_lo, h_hi, refine_steps, geometric=True)
            fine_rp = box_nodes(rp_lo, rp_hi, refine_steps, geometric=False)
            seen.update({(r["h_over_d"], r["r_p"]): r for r in stage(fine_h, fine_rp)})
            h_ratio = (h_hi / h_lo) ** (1 / (refine_steps - 1))
            rp_step = (rp_hi - rp_lo) / (refine_steps - 1)
    dtype = np.float64 if criterion == "seat_probability" else np.int64
    coarse = np.array([[seen[(h, rp)][column] for rp in rps] for h in hs], dtype=dtype)
    return DesignSearch(
        face=face,
        criterion=criterion,
        h_over_d=hs,
        r_p=rps,
        coarse=coarse,
        ranked=_rank(list(seen.values()), column),
        coarse_best=_rank(coarse_rows, column)[0],
        rounds=refine,
    )
