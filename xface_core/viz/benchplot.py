"""The work-precision plot of ``xface bench``, drawn with pillow (the ``viz`` extra)."""

from __future__ import annotations

import math
from pathlib import Path

from PIL import Image, ImageDraw

__all__ = ["plot_work_precision"]


def plot_work_precision(rows: list[dict[str, object]], out: Path) -> None:
    """Write ``out/work_precision.png``: log-log final-state error (max and 99th percentile)
    against time per map, with each setting's rtol and its non-boundary map mismatches.

    ``rows`` are the work-precision rows of :mod:`xface_core.bench` (keys ``symmetry``,
    ``ms_per_map``, ``max_state_err_rad``, ``p99_state_err_rad``, ``mismatch_other``,
    ``rtol``, ``default``).
    """
    pts = [r for r in rows if r["symmetry"]]
    t = [math.log10(float(r["ms_per_map"])) for r in pts]  # type: ignore[arg-type]
    e_max = [math.log10(max(float(r["max_state_err_rad"]), 1e-16)) for r in pts]  # type: ignore[arg-type]
    e_p99 = [math.log10(max(float(r["p99_state_err_rad"]), 1e-16)) for r in pts]  # type: ignore[arg-type]
    w, h, pad = 760, 500, 80
    img = Image.new("RGB", (w, h), "white")
    draw = ImageDraw.Draw(img)
    x0, x1 = min(t) - 0.05, max(t) + 0.05
    y0, y1 = min(e_p99 + e_max) - 0.5, max(e_p99 + e_max) + 0.5

    def px(x: float, y: float) -> tuple[float, float]:
        return (
            pad + (x - x0) / (x1 - x0) * (w - 2 * pad),
            h - pad - (y - y0) / (y1 - y0) * (h - 2 * pad),
        )

    draw.rectangle([pad, pad, w - pad, h - pad], outline="black")
    for e in range(math.ceil(y0), math.floor(y1) + 1):
        _, yy = px(x0, e)
        draw.line([pad, yy, w - pad, yy], fill=(225, 225, 225))
        draw.text((12, yy - 6), f"1e{e}", fill="black")
    for k in range(5):
        xv = x0 + (x1 - x0) * (k + 0.5) / 5
        xx, _ = px(xv, y0)
        draw.line([xx, h - pad, xx, h - pad + 5], fill="black")
        draw.text((xx - 14, h - pad + 10), f"{10**xv:.1f}", fill="black")
    for series, color in ((e_max, (30, 90, 200)), (e_p99, (120, 120, 120))):
        line = [px(a, b) for a, b in zip(t, series, strict=True)]
        draw.line(line, fill=color, width=2)
        for k, (a, b) in enumerate(line):
            r = pts[k]
            dot = (200, 30, 30) if r["mismatch_other"] else (30, 150, 60)
            draw.ellipse([a - 4, b - 4, a + 4, b + 4], fill=dot)
            if series is e_max:
                label = f"{float(r['rtol']):.0e}"  # type: ignore[arg-type]
                label += f" ({r['mismatch_other']})" + (" default" if r["default"] else "")
                draw.text((a + 6, b - 16 if k % 2 else b + 4), label, fill="black")
    draw.text((w // 2 - 120, h - 40), "time per 41 x 41 map (ms, log scale)", fill="black")
    draw.text(
        (pad, 16),
        "final-angle error vs reference (rad, log): blue max, grey 99th percentile",
        fill="black",
    )
    draw.text(
        (pad, 34),
        "label: rtol (non-boundary map mismatches); red dot: some mismatch, green: none",
        fill="black",
    )
    img.save(out / "work_precision.png")
