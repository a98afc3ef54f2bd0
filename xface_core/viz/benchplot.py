"""The work-precision plot of ``xface bench``: a log-log matplotlib figure (the ``viz`` extra).

Each solver setting is a point per error measure: the final-angle error against the
reference (maximum and 99th percentile, rad) over the median time per 41 x 41 map (ms).
The setting's rtol is the point's colour (a colour bar, not labels, so nothing overlaps
however close the points are); settings whose maps differ from the reference off an outcome
boundary get a red edge and their count; the default setting is ringed, and its run without
the mirror-symmetry skip is drawn hollow.

Replot from a bench's CSV without running the bench again::

    python -m xface_core.viz.benchplot docs/bench/work_precision.csv docs/bench
"""

from __future__ import annotations

import argparse
import csv
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
from matplotlib.axis import Axis
from matplotlib.colors import LogNorm
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter

from xface_core.errors import XfaceValueError
from xface_core.viz.figures import new_figure, pt, save

__all__ = ["plot_work_precision", "read_work_precision_csv", "work_precision_figure"]

#: The columns the plot reads, and how a CSV cell becomes a value.
_COLUMNS: dict[str, Callable[[str], object]] = {
    "rtol": float,
    "symmetry": lambda s: s == "True",
    "default": lambda s: s == "True",
    "ms_per_map": float,
    "max_state_err_rad": float,
    "p99_state_err_rad": float,
    "mismatch_other": int,
}
#: Errors below this are drawn at it (a log axis has no zero).
_FLOOR = 1e-16
_MISMATCH = (0.84, 0.15, 0.15)


def read_work_precision_csv(path: str | Path) -> list[dict[str, object]]:
    """The rows of a ``work_precision.csv`` written by ``xface bench``, typed as the bench
    made them (floats, bools, ints) for the columns the plot needs.

    Raises
    ------
    XfaceValueError
        A column is missing or a value does not parse.
    """
    with open(path, newline="") as fh:
        raw = list(csv.DictReader(fh))
    rows: list[dict[str, object]] = []
    for k, row in enumerate(raw, start=2):
        try:
            rows.append({name: parse(row[name]) for name, parse in _COLUMNS.items()})
        except (KeyError, TypeError, ValueError) as exc:
            raise XfaceValueError(f"{path}: line {k}: not a work-precision row ({exc})") from None
    return rows


def _series(pts: list[dict[str, object]], key: str) -> np.ndarray:
    return np.maximum(np.array([float(r[key]) for r in pts]), _FLOOR)  # type: ignore[arg-type]


def _plain_log_ticks(axis: Axis, lo: float, hi: float) -> None:
    """Label a log axis at 1, 1.5, 2, 2.5, 3, 4, 5, 7 x 10^k written plainly ("150", not
    "1.5 x 10^2"): the bench's times span less than a decade, where a log axis would
    otherwise show one labelled tick or none."""
    k0, k1 = int(np.floor(np.log10(lo))), int(np.ceil(np.log10(hi)))
    ticks = [m * 10.0**k for k in range(k0, k1 + 1) for m in (1, 1.5, 2, 2.5, 3, 4, 5, 7)]
    inside = [v for v in ticks if lo / 1.1 <= v <= hi * 1.1]
    if len(inside) > 8:  # more than a decade: the decades alone
        inside = [10.0**k for k in range(k0, k1 + 1) if lo / 1.1 <= 10.0**k <= hi * 1.1]
    axis.set_major_locator(FixedLocator(inside))
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_formatter(NullFormatter())


def work_precision_figure(rows: Sequence[dict[str, object]]) -> Figure:
    """The log-log figure of the bench's work-precision rows (keys ``rtol``, ``symmetry``,
    ``default``, ``ms_per_map``, ``max_state_err_rad``, ``p99_state_err_rad``,
    ``mismatch_other``).

    Raises
    ------
    XfaceValueError
        No row with the symmetry skip on (the rows the plot is about).
    """
    pts = [r for r in rows if r["symmetry"]]
    if not pts:
        raise XfaceValueError("no work-precision rows with the symmetry skip on to plot")
    fig = new_figure()
    fig.set_size_inches(8.0, 5.6)
    fig.set_layout_engine("constrained")
    ax = fig.add_subplot()
    ax.set_xscale("log")
    ax.set_yscale("log")
    t = np.array([float(r["ms_per_map"]) for r in pts])  # type: ignore[arg-type]
    rtol = np.array([float(r["rtol"]) for r in pts])  # type: ignore[arg-type]
    norm = LogNorm(vmin=float(rtol.min()), vmax=float(rtol.max()) * (1.0 + 1e-9))
    mismatch = np.array([int(r["mismatch_other"]) for r in pts])  # type: ignore[call-overload]
    edges = [_MISMATCH if m else "black" for m in mismatch]
    dots = None
    for key, marker in (("max_state_err_rad", "o"), ("p99_state_err_rad", "s")):
        err = _series(pts, key)
        dots = ax.scatter(
            t, err, c=rtol, cmap="viridis", norm=norm, marker=marker, s=pt(12) ** 2,
            edgecolors=edges, linewidths=[pt(2.5) if m else pt(0.8) for m in mismatch], zorder=3,
        )  # fmt: skip
        for x, y, m in zip(t, err, mismatch, strict=True):
            if m:
                ax.annotate(str(m), (x, y), xytext=(6, 4), textcoords="offset points",
                            fontsize=8, color=_MISMATCH)  # fmt: skip
    for r in rows:
        if not r["default"]:
            continue
        x = float(r["ms_per_map"])  # type: ignore[arg-type]
        ys = [max(float(r[k]), _FLOOR) for k in ("max_state_err_rad", "p99_state_err_rad")]  # type: ignore[arg-type]
        if r["symmetry"]:
            ax.scatter([x, x], ys, s=pt(26) ** 2, facecolors="none", edgecolors="black",
                       linewidths=pt(1.2), zorder=2)  # fmt: skip
        else:
            ax.scatter([x, x], ys, s=pt(12) ** 2, facecolors="none", edgecolors="black",
                       linewidths=pt(1.2), marker="D", zorder=3)  # fmt: skip
    assert dots is not None
    bar = fig.colorbar(dots, ax=ax, pad=0.02)
    bar.set_label("rtol (relative tolerance; atol = rtol / 100)", fontsize=9)
    _plain_log_ticks(ax.xaxis, float(t.min()), float(t.max()))
    ax.tick_params(which="both", labelsize=9)
    ax.grid(True, which="major", color="0.88", linewidth=pt(1))
    ax.grid(True, which="minor", axis="x", color="0.94", linewidth=pt(1))
    ax.set_xlabel("median time per 41 x 41 map (ms, log scale)", fontsize=10)
    ax.set_ylabel("final-angle error against the reference (rad, log scale)", fontsize=10)
    ax.set_title("Work precision: error against time, one point per solver setting", fontsize=11)
    y_lo, y_hi = ax.get_ylim()
    ax.set_ylim(y_lo / 3.0, y_hi * 3.0)  # room for the rings at the ends
    gray = "0.45"
    handles = [
        Line2D([], [], marker="o", color=gray, linestyle="none", label="maximum error"),
        Line2D([], [], marker="s", color=gray, linestyle="none", label="99th percentile"),
        Line2D([], [], marker="o", markerfacecolor="none", markeredgecolor="black",
               markersize=14, linestyle="none", label="the default setting"),
        Line2D([], [], marker="D", markerfacecolor="none", markeredgecolor="black",
               linestyle="none", label="the default without the mirror-symmetry skip"),
        Line2D([], [], marker="o", markerfacecolor=gray, markeredgecolor=_MISMATCH,
               markeredgewidth=2.5, linestyle="none",
               label="map nodes off a boundary differ from the reference (count)"),
    ]  # fmt: skip
    fig.legend(handles=handles, loc="outside lower center", ncols=2, fontsize=9, frameon=False)
    return fig


def plot_work_precision(rows: list[dict[str, object]], out: Path) -> None:
    """Write ``out/work_precision.png`` (see :func:`work_precision_figure`)."""
    save(work_precision_figure(rows), Path(out) / "work_precision.png", "png")


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m xface_core.viz.benchplot CSV OUT``: replot a bench's CSV into OUT."""
    parser = argparse.ArgumentParser(description=main.__doc__)
    parser.add_argument("csv", help="work_precision.csv of an xface bench run")
    parser.add_argument("out", help="folder to write work_precision.png to")
    args = parser.parse_args(argv)
    try:
        plot_work_precision(read_work_precision_csv(args.csv), Path(args.out))
    except (OSError, XfaceValueError) as exc:
        print(f"benchplot: error: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {Path(args.out) / 'work_precision.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
