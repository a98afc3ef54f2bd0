"""Acceptance maps over grids of initial poses, and the paper's M tables.

A map runs one design over a grid of (x0, theta0); the paper's metric M counts the SEATED
cells of the 41 x 41 grid x0 in [-D, D], theta0 in [-pi/2, pi/2]. A table runs a map per
design over the paper's 11 H/D values x 11 r_p values.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from multiprocessing import get_context
from typing import Literal

import numpy as np
import numpy.typing as npt

from xface_core.codes import Outcome
from xface_core.errors import XfaceValueError
from xface_core.geometry import FaceDesign, make_face
from xface_core.physics import Physics, SolverSettings
from xface_core.runner import outcomes_at, process_count

from .bounds import bound_table
from .grids import PAPER_GRID_SIZE, PAPER_H_OVER_D, PAPER_R_P, ThetaGridKind, theta_grid, x0_grid
from .regions import CellRect, largest_centred_rectangle, largest_rectangle

__all__ = ["AcceptanceMap", "MTable", "acceptance_map", "m_table"]

Method = Literal["sim", "bound"]


@dataclass(frozen=True, eq=False)
class AcceptanceMap:
    """Outcomes of one design over a grid of initial poses.

    Attributes
    ----------
    design : FaceDesign
    x0 : (n,) float
        Row values: lateral offsets from -D to D (the design's length unit).
    theta0 : (m,) float
        Column values: initial angles (rad).
    outcomes : (n, m) int8
        :class:`Outcome` value per cell.
    guaranteed : (range, range) or None
        Largest all-SEATED rectangle of cells as (rows, cols) index ranges.
    centred : (range, range) or None
        Largest all-SEATED rectangle centred on the aligned pose.
    """

    design: FaceDesign
    x0: npt.NDArray[np.float64]
    theta0: npt.NDArray[np.float64]
    outcomes: npt.NDArray[np.int8]
    guaranteed: CellRect | None
    centred: CellRect | None

    @property
    def M(self) -> int:
        """Number of SEATED cells (the paper's metric)."""
        return int(np.count_nonzero(self.outcomes == Outcome.SEATED))

    def counts(self) -> dict[Outcome, int]:
        """Number of cells per outcome."""
        values = np.bincount(self.outcomes.ravel(), minlength=len(Outcome))
        return {o: int(values[o]) for o in Outcome}

    def region_extent(self, rect: CellRect | None) -> tuple[float, float, float, float] | None:
        """(x0_min, x0_max, theta0_min, theta0_max) of a rectangle of cells."""
        if rect is None:
            return None
        rows, cols = rect
        return (
            float(self.x0[rows.start]),
            float(self.x0[rows.stop - 1]),
            float(self.theta0[cols.start]),
            float(self.theta0[cols.stop - 1]),
        )


def acceptance_map(
    design: FaceDesign,
    *,
    grid: int = PAPER_GRID_SIZE,
    theta_kind: ThetaGridKind = "symmetric",
    physics: Physics | None = None,
    damping_ratio: float | None = None,
    friction: float | None = None,
    settings: SolverSettings | None = None,
    use_symmetry: bool = True,
    coarse: int | None = None,
    threads: int | None = None,
    progress: Progress | None = None,
) -> AcceptanceMap:
    """Simulate every node of a ``grid x grid`` map (rows x0 from -D to D, columns theta0
    from -pi/2 to pi/2, built from integers so mirrored nodes are exact negatives).

    With ``use_symmetry`` and a mirror-symmetric design on the symmetric grid, only half the
    nodes are simulated and the rest are mirrored: outcome(x0, theta0) = outcome(-x0, -theta0)
    holds exactly for such designs (the test suite checks it with ``use_symmetry=False``).

    ``coarse`` (an odd node count with ``(grid - 1) % (coarse - 1) == 0``) turns on
    boundary-following refinement for large grids: the coarse map is simulated first, every
    coarse cell whose four corners agree is filled with their outcome, and only the fine
    nodes of cells with differing corners are simulated. An island of another outcome that
    fits inside one coarse cell without touching its corners is missed, so exact full grids
    (the default) are used for the paper's tables; ``xface bench`` measures the trade.

    ``progress(done, total)``, when given, is called as batches of poses finish (not with
    ``coarse``); the outcomes do not depend on it.

    Examples
    --------
    >>> from xface_core import x_face
    >>> amap = acceptance_map(x_face(1.0, 2.0), grid=11)
    >>> amap.outcomes.shape, amap.M > 0
    ((11, 11), True)
    """
    phys = Physics.resolve(
        physics, damping_ratio=damping_ratio, friction=friction, settings=settings
    )
    x_d = x0_grid(grid)
    th = theta_grid(grid, theta_kind)
    X, T = np.meshgrid(x_d, th, indexing="ij")
    if coarse is not None:
        outcomes = _refined_outcomes(
            design,
            X,
            T,
            grid,
            coarse,
            theta_kind,
            phys,
            use_symmetry,
            threads,
        )
    elif use_symmetry and design.mirror_symmetric and theta_kind == "symmetric":
        flat = X.size
        half = flat // 2 + 1  # cells k <= centre; cell flat-1-k is the mirror of cell k
        res = _batch_outcomes(design, X.ravel()[:half], T.ravel()[:half], phys, threads, progress)
        out = np.empty(flat, dtype=np.int8)
        out[:half] = res
        out[half:] = res[: flat - half][::-1]
        outcomes = out.reshape(X.shape)
    else:
        outcomes = _batch_outcomes(design, X.ravel(), T.ravel(), phys, threads, progress).reshape(
            X.shape
        )
    seated = outcomes == Outcome.SEATED
    return AcceptanceMap(
        design=design,
        x0=x_d * design.width,
        theta0=th,
        outcomes=outcomes,
        guaranteed=largest_rectangle(seated),
        centred=largest_centred_rectangle(seated),
    )


#: Called with (poses or designs done, total) as a long computation goes on.
Progress = Callable[[int, int], None]

#: Poses per batch when a map reports its progress (a few per second on two cores).
PROGRESS_CHUNK = 20_000


def _batch_outcomes(
    design: FaceDesign,
    x0: npt.NDArray[np.float64],
    theta0: npt.NDArray[np.float64],
    physics: Physics,
    threads: int | None,
    progress: Progress | None,
) -> npt.NDArray[np.int8]:
    """Outcomes of flat pose arrays (x0 in D), in chunks that report ``progress`` when it is
    given (each pose's result is the same whatever the chunking)."""
    if progress is None:
        return outcomes_at(design, x0, theta0, physics, threads=threads)
    out = np.empty(x0.size, dtype=np.int8)
    for start in range(0, x0.size, PROGRESS_CHUNK):
        stop = min(start + PROGRESS_CHUNK, x0.size)
        out[start:stop] = outcomes_at(
            design, x0[start:stop], theta0[start:stop], physics, threads=threads
        )
        progress(stop, x0.size)
    return out


def _refined_outcomes(
    design: FaceDesign,
    X: npt.NDArray[np.float64],
    T: npt.NDArray[np.float64],
    grid: int,
    coarse: int,
    theta_kind: ThetaGridKind,
    physics: Physics,
    use_symmetry: bool,
    threads: int | None,
) -> npt.NDArray[np.int8]:
    if coarse < 3 or coarse % 2 == 0 or coarse >= grid or (grid - 1) % (coarse - 1):
        raise XfaceValueError(
            f"coarse must be odd, >= 3, < grid and divide the grid: grid={grid}, coarse={coarse}"
        )
    f = (grid - 1) // (coarse - 1)
    coarse_map = acceptance_map(
        design,
        grid=coarse,
        theta_kind=theta_kind,
        physics=physics,
        use_symmetry=use_symmetry,
        threads=threads,
    ).outcomes
    out = np.full((grid, grid), -1, dtype=np.int8)
    out[::f, ::f] = coarse_map
    todo = np.zeros((grid, grid), dtype=bool)
    for i in range(coarse - 1):
        for j in range(coarse - 1):
            corners = coarse_map[i : i + 2, j : j + 2]
            block = (slice(i * f, (i + 1) * f + 1), slice(j * f, (j + 1) * f + 1))
            if (corners == corners[0, 0]).all():
                sub = out[block]
                sub[sub < 0] = corners[0, 0]
            else:
                todo[block] = True
    todo &= out < 0
    if todo.any():
        out[todo] = outcomes_at(design, X[todo], T[todo], physics, threads=threads)
    return out


@dataclass(frozen=True, eq=False)
class MTable:
    """M over a table of designs (rows H/D, columns r_p), like the paper's Tables II-IV."""

    face: str
    method: Method
    h_over_d: npt.NDArray[np.float64]
    r_p: npt.NDArray[np.float64]
    M: npt.NDArray[np.int64]
    theta_kind: ThetaGridKind


def _map_m(
    args: tuple[str, float, float, int, ThetaGridKind, Physics, int],
) -> int:
    face, h, rp, grid, theta_kind, physics, threads = args
    return acceptance_map(
        make_face(face, h, rp), grid=grid, theta_kind=theta_kind, physics=physics, threads=threads
    ).M


def m_table(
    face: str,
    *,
    method: Method = "sim",
    theta_kind: ThetaGridKind = "symmetric",
    h_over_d: Sequence[float] = PAPER_H_OVER_D,
    r_p: Sequence[float] = PAPER_R_P,
    grid: int = PAPER_GRID_SIZE,
    physics: Physics | None = None,
    damping_ratio: float | None = None,
    friction: float | None = None,
    settings: SolverSettings | None = None,
    workers: int | None = None,
    progress: Progress | None = None,
) -> MTable:
    """M for every design of a table: simulated (``"sim"``) or the paper's closed-form
    best-case bound (``"bound"``, V and S faces only).

    ``workers`` processes share the maps (default: all cores); results do not depend on it.
    ``progress(done, total)``, when given, is called as each design's map finishes.

    Examples
    --------
    >>> t = m_table("V", method="bound", theta_kind="paper")
    >>> int(t.M[0, 1])  # Table III prints 739
    739
    """
    phys = Physics.resolve(
        physics, damping_ratio=damping_ratio, friction=friction, settings=settings
    )
    face = face.upper()
    if method == "bound":
        if face not in ("V", "S"):
            raise XfaceValueError("the closed-form bound exists for the V and S faces only")
        m = bound_table(face, theta_grid=theta_kind, h_over_d=h_over_d, r_p=r_p, n=grid)  # type: ignore[arg-type]
    elif method == "sim":
        # One thread per process: the processes already use every core.
        jobs = [
            (face, float(h), float(rp), grid, theta_kind, phys, 1) for h in h_over_d for rp in r_p
        ]
        n_workers = process_count(workers, len(jobs))
        values: list[int] = []
        if n_workers <= 1:
            results: Iterable[int] = map(_map_m, jobs)
            for m_value in results:
                values.append(m_value)
                if progress is not None:
                    progress(len(values), len(jobs))
        else:
            _map_m(jobs[0])  # compile (or load) the engine once before forking
            with ProcessPoolExecutor(n_workers, mp_context=get_context("fork")) as pool:
                for m_value in pool.map(_map_m, jobs, chunksize=4):
                    values.append(m_value)
                    if progress is not None:
                        progress(len(values), len(jobs))
        m = np.asarray(values, dtype=np.int64).reshape(len(h_over_d), len(r_p))
    else:
        raise XfaceValueError(f"method must be 'sim' or 'bound', got {method!r}")
    return MTable(
        face=face,
        method=method,
        h_over_d=np.asarray(h_over_d, dtype=np.float64),
        r_p=np.asarray(r_p, dtype=np.float64),
        M=np.asarray(m, dtype=np.int64),
        theta_kind=theta_kind,
    )
