"""The paper's M tables (Tables II-IV of Eckenstein & Yim) as packaged data.

M is the number of successful docks out of the 41 x 41 grid of initial conditions, per design
(rows: H/D, columns: r_p). Table II (X-Face) is the paper's simulation; Tables III (V-Face)
and IV (S-Face) are its closed-form "best case" bounds. Two rows of Table IV
(H/D = 9.1896 and 16) are missing from the source; they are NaN here.

The CSV files live in ``xface_core/data`` and are read with :mod:`importlib.resources`, so
they work from an installed wheel as well as from a checkout.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from importlib import resources
from typing import Final, Literal

import numpy as np
import numpy.typing as npt

from xface_core.errors import XfaceValueError

from .grids import PAPER_H_OVER_D, PAPER_R_P

__all__ = [
    "DEPARTURE_FROM_PAPER",
    "PAPER_MEAN_RATIO_XS",
    "PAPER_MEAN_RATIO_XV",
    "PaperFace",
    "PaperTable",
    "mean_ratio",
    "paper_table",
]

FloatArray = npt.NDArray[np.float64]
PaperFace = Literal["X", "V", "S"]

#: Mean over the design space of M(X-Face) / M(V-Face), as printed in Section IV.
PAPER_MEAN_RATIO_XV: Final = 1.8838
#: Mean over the design space of M(X-Face) / M(S-Face), as printed in Section IV. It cannot
#: be recomputed from the printed tables alone: two rows of Table IV are missing.
PAPER_MEAN_RATIO_XS: Final = 2.3846

#: Where and why the simulation departs from the paper's simulated Table II, in one line (the
#: commands that print simulated M values or recommend a design say it; docs/paper.md has the
#: cases and the evidence).
DEPARTURE_FROM_PAPER: Final = (
    "departs from the paper: with both parts free and two layers, flat teeth at r_p >= 1 seat "
    "far less (a tilted part's corner turns it away), and with the physical reach "
    "|x0| <= L = 2 r_p + H/D, r_p = 0 seats far more (the paper's shorter reach r_p + H/2 "
    "loses it); why, cell by cell: docs/paper.md"
)

_FILES: Final[dict[str, str]] = {
    "X": "table2_xface_M.csv",
    "V": "table3_vface_M.csv",
    "S": "table4_sface_M.csv",
}
_TITLES: Final[dict[str, str]] = {
    "X": "Table II: M(X-Face), simulated",
    "V": "Table III: M(V-Face), best-case bound",
    "S": "Table IV: M(S-Face), best-case bound",
}


@dataclass(frozen=True, eq=False)
class PaperTable:
    """One of the paper's M tables.

    Attributes
    ----------
    face : {"X", "V", "S"}
    title : str
        The table's caption, e.g. ``"Table III: M(V-Face), best-case bound"``.
    h_over_d : numpy.ndarray
        Shape ``(11,)``: the row keys H/D as printed (:data:`~.grids.PAPER_H_OVER_D`).
    r_p : numpy.ndarray
        Shape ``(11,)``: the column keys r_p = 0..10 (pivot distance in widths D).
    M : numpy.ndarray
        Shape ``(11, 11)``, float64: successes out of 1681, rows = H/D, columns = r_p; NaN
        where the source has no value. The arrays are read-only.
    """

    face: PaperFace
    title: str
    h_over_d: FloatArray
    r_p: FloatArray
    M: FloatArray

    @property
    def known(self) -> npt.NDArray[np.bool_]:
        """Mask of the cells the paper prints (False for the missing rows of Table IV)."""
        return np.isfinite(self.M)

    def value(self, h_over_d: float, r_p: float) -> float:
        """The printed M for one design (NaN if the source lacks it).

        Parameters
        ----------
        h_over_d, r_p : float
            Must be one of the table's keys exactly.

        Raises
        ------
        XfaceValueError
            If the design is not a cell of the table.

        Examples
        --------
        >>> paper_table("V").value(1.0, 2.0)
        236.0
        """
        rows = np.flatnonzero(self.h_over_d == h_over_d)
        cols = np.flatnonzero(self.r_p == r_p)
        if rows.size != 1 or cols.size != 1:
            raise XfaceValueError(
                f"({h_over_d!r}, {r_p!r}) is not a cell of {self.title}; H/D must be one of "
                f"{list(PAPER_H_OVER_D)} and r_p one of 0..10"
            )
        return float(self.M[rows[0], cols[0]])


def _read_only(a: FloatArray) -> FloatArray:
    a.flags.writeable = False
    return a


def _parse(face: str, text: str) -> FloatArray:
    """Parse a packaged CSV into an (11, 11) array, NaN for rows the file lacks."""
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    reader = csv.reader(io.StringIO("\n".join(lines)))
    header = next(reader)
    expected = ["h_over_d"] + [f"rp{int(r)}" for r in PAPER_R_P]
    if [h.strip() for h in header] != expected:
        raise XfaceValueError(f"unexpected header in {_FILES[face]}: {header}")
    table = np.full((len(PAPER_H_OVER_D), len(PAPER_R_P)), np.nan)
    for row in reader:
        key = float(row[0])
        matches = [i for i, h in enumerate(PAPER_H_OVER_D) if math.isclose(h, key, rel_tol=0.0)]
        if len(matches) != 1 or len(row) != len(PAPER_R_P) + 1:
            raise XfaceValueError(f"unexpected row in {_FILES[face]}: {row}")
        table[matches[0]] = [float(v) for v in row[1:]]
    return table


def paper_table(face: PaperFace) -> PaperTable:
    """Load one of the paper's M tables.

    Parameters
    ----------
    face : {"X", "V", "S"}
        ``"X"``: Table II (simulated); ``"V"``: Table III and ``"S"``: Table IV (best-case
        bounds).

    Returns
    -------
    PaperTable
        With ``M`` of shape ``(11, 11)``; Table IV has NaN in its last two rows.

    Raises
    ------
    XfaceValueError
        If ``face`` is not one of "X", "V", "S".

    Examples
    --------
    >>> t = paper_table("S")
    >>> t.M.shape, int(t.known.sum()), float(t.M[0, 0])
    ((11, 11), 99, 38.0)
    >>> paper_table("X").value(0.0625, 1.0)
    820.0
    """
    if face not in _FILES:
        raise XfaceValueError(f"face must be 'X', 'V' or 'S', got {face!r}")
    text = resources.files("xface_core.data").joinpath(_FILES[face]).read_text("utf-8")
    return PaperTable(
        face=face,
        title=_TITLES[face],
        h_over_d=_read_only(np.array(PAPER_H_OVER_D, dtype=np.float64)),
        r_p=_read_only(np.array(PAPER_R_P, dtype=np.float64)),
        M=_read_only(_parse(face, text)),
    )


def mean_ratio(numerator: npt.ArrayLike, denominator: npt.ArrayLike) -> float:
    """Mean of the cell-by-cell ratio of two M tables, the paper's headline statistic.

    Cells where either table is NaN are left out (so the paper's X/S ratio, taken over 121
    cells, cannot be reproduced from the 99 printed cells of Table IV).

    Parameters
    ----------
    numerator, denominator : array_like
        Tables of equal shape.

    Returns
    -------
    float

    Raises
    ------
    XfaceValueError
        If the shapes differ, no cell is usable, or a usable denominator cell is <= 0.

    Examples
    --------
    >>> round(mean_ratio(paper_table("X").M, paper_table("V").M), 4) == PAPER_MEAN_RATIO_XV
    True
    """
    num = np.asarray(numerator, dtype=np.float64)
    den = np.asarray(denominator, dtype=np.float64)
    if num.shape != den.shape:
        raise XfaceValueError(f"table shapes differ: {num.shape} and {den.shape}")
    usable = np.isfinite(num) & np.isfinite(den)
    if not usable.any():
        raise XfaceValueError("no cell has a value in both tables")
    if (den[usable] <= 0).any():
        raise XfaceValueError("a denominator cell is <= 0; the ratio is undefined")
    return float(np.mean(num[usable] / den[usable]))
