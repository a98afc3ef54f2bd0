"""Seat probability under pose uncertainty, integrated over the acceptance atlas.

The true pose (x0, theta0) is taken as Gaussian around the estimate with a 2 x 2 covariance.
The probability of a seat is the Gaussian's mass over the SEATED region. It is integrated in
the Gaussian's own polar coordinates: with ``pose = mean + A z``, ``A A^T = cov`` and ``z``
standard normal, the direction of ``z`` is uniform and its length has the Rayleigh
distribution, whose mass between radii a and b is ``exp(-a^2/2) - exp(-b^2/2)`` exactly. So

    P = mean over rays of  sum over the SEATED stretches [a, b] of the ray
        of ( exp(-a^2/2) - exp(-b^2/2) ).

Each ray is sampled at least twice per atlas cell. A sample whose atlas cell has four SEATED
corners counts as seated, four non-SEATED corners as not; any other sample (a boundary runs
through its cell, or it lies outside the atlas) is simulated exactly. Where two neighbouring
samples differ, the crossing is bisected by exact simulations, so the boundaries that carry
the Gaussian's mass are exact to 1/16 of a sample spacing. With ``boundary="atlas"`` a
sample in a boundary cell, and each bisection step, is read from the chord between the
flips on the cell's edges where that cell's chord passed its check
(:meth:`~xface_core.atlas.build.AcceptanceAtlas.seated_by_flips`) and simulated only
elsewhere: no simulation at all for most queries, at the cost of the chords' error
(docs/atlas.md). The rays integrate the rest, by
adaptive trapezoids in angle (16 evenly spaced, then more where neighbouring rays' masses
disagree: where a ray grazes a boundary or passes a corner of the SEATED region), or ``rays``
evenly spaced ones.

Mass outside the atlas is not guessed: beyond |x0| = L a sample is OUT_OF_REACH by the
engine's first rule (not simulated); the others are simulated like any other (beyond
|theta0| = 2 pi INVALID_INPUT: not seated). Mass beyond
5 standard deviations (3.7e-6) takes the outcome of the ray's last sample.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from xface_core.codes import Outcome
from xface_core.errors import InputError, XfaceValueError, is_integer_in, is_positive_up_to
from xface_core.geometry import FaceDesign
from xface_core.physics import Physics
from xface_core.runner import outcomes_at

from .build import AcceptanceAtlas, build_atlas

__all__ = [
    "BOUNDARIES",
    "DEFAULT_RAYS",
    "DEFAULT_RAY_TOL",
    "RAY_RADIUS",
    "checked_covariances",
    "pose_factors",
    "seat_probability",
]

FloatArray = npt.NDArray[np.float64]

#: Rays per query with a fixed count (``rays=``; evenly spaced directions of the whitened
#: Gaussian), the quadrature before the adaptive one became the default.
DEFAULT_RAYS = 128
#: The adaptive quadrature's first rays (evenly spaced), each interval between two of them
#: then checked by the ray through its middle.
FIRST_RAYS = 16
#: An interval of rays is split while adding its middle ray changes its trapezoid by more
#: than this times the interval's share of the circle (the error kept is well below it).
#: Over 48 straddling queries (scripts/bench/bench_seat_probability.py), against 1024 even rays:
#: largest error 2.0e-3, median 4.7e-5, 36 rays and 22 ms (medians); 128 even rays: 2.4e-3,
#: 1.6e-5, 43 ms.
DEFAULT_RAY_TOL = 0.1
#: Splits of an interval at most: the narrowest is 2 pi / (FIRST_RAYS * 2^MAX_SPLITS).
MAX_SPLITS = 7
#: Rays end at this many standard deviations (mass beyond: exp(-12.5) = 3.7e-6).
RAY_RADIUS = 5.0
#: Samples per ray at most (a Gaussian much wider than the atlas is sampled more coarsely
#: than twice per cell; see docs/atlas.md).
MAX_RAY_SAMPLES = 1024
#: Bisection steps of each crossing (1/16 of a sample spacing). More buy nothing the rays'
#: quadrature does not lose: over 48 straddling queries 6 steps took 1.28 times as long and
#: left the largest error against 1024 rays the same, 2.4e-3
#: (scripts/bench/bench_seat_probability.py, docs/atlas.md).
CROSSING_STEPS = 4
#: Where a boundary runs through an atlas cell: ``"exact"`` simulates the samples there and
#: bisects their crossings by simulation; ``"atlas"`` draws the boundary straight between
#: the flips on the cell's edges (an atlas built with ``every_flip`` has them all) and
#: simulates only where none can be drawn.
BOUNDARIES = ("exact", "atlas")


def checked_covariances(cov: npt.ArrayLike, n: int) -> FloatArray:
    """``cov`` as an (n, 2, 2) array, after checking it: finite, symmetric (to 1e-9 of its
    largest entry) and positive semi-definite (to 1e-12 of its largest eigenvalue).

    Raises :class:`XfaceValueError` naming what is wrong.
    """
    c = np.asarray(cov, dtype=np.float64)
    if c.shape == (2, 2):
        c = np.broadcast_to(c, (n, 2, 2))
    if c.shape != (n, 2, 2):
        raise XfaceValueError(f"cov must have shape (2, 2) or ({n}, 2, 2), got {c.shape}")
    if not np.isfinite(c).all():
        raise XfaceValueError("cov must be finite")
    scale = np.abs(c).max(axis=(1, 2))
    asym = np.abs(c[:, 0, 1] - c[:, 1, 0])
    if (asym > 1e-9 * scale).any():
        raise XfaceValueError(
            f"cov must be symmetric, got off-diagonals differing by {asym.max():g}"
        )
    eig = np.linalg.eigvalsh(c)
    if (eig[:, 0] < -1e-12 * np.maximum(eig[:, 1], 0.0) - 1e-300).any():
        raise XfaceValueError(
            f"cov must be positive semi-definite, got an eigenvalue {eig[:, 0].min():g}"
        )
    return np.array(c)


def pose_factors(cov_d: FloatArray) -> FloatArray:
    """Per query a 2 x 2 ``A`` with ``A A^T = cov`` (symmetric square root: also for a
    singular covariance, where a Cholesky factor does not exist)."""
    eig, vec = np.linalg.eigh(cov_d)
    root = np.sqrt(np.clip(eig, 0.0, None))
    return np.asarray(vec * root[:, None, :], dtype=np.float64)


def _rayleigh_tail(r: FloatArray) -> FloatArray:
    """Mass of the standard 2-D normal beyond radius r."""
    return np.asarray(np.exp(-0.5 * r * r), dtype=np.float64)


def _samples_per_ray(atlas: AcceptanceAtlas, factor: FloatArray) -> int:
    """Samples along every ray: at most half an atlas cell apart in the direction the
    Gaussian stretches most (the largest singular value of ``A`` in grid units)."""
    grid = np.diag([1.0 / atlas.lateral_step, 1.0 / atlas.angle_step]) @ factor
    stretch = float(np.linalg.svd(grid, compute_uv=False)[0])
    return int(min(MAX_RAY_SAMPLES, max(8, math.ceil(RAY_RADIUS * stretch / 0.5))))


def _seated(
    atlas: AcceptanceAtlas, xs: FloatArray, ts: FloatArray, boundary: str
) -> npt.NDArray[np.int8]:
    """1 where a pose (D, rad) seats, else 0: from the atlas where its cell's corners agree
    (``boundary="atlas"``: also from the straight boundary between the cell's edge flips,
    :meth:`~xface_core.atlas.build.AcceptanceAtlas.seated_by_flips`), else simulated."""
    seated = atlas.seated_by_flips(xs, ts) if boundary == "atlas" else atlas.seated_in_cell(xs, ts)
    # Beyond the mated distance the engine's first rule ends every run OUT_OF_REACH.
    seated[np.abs(xs) > atlas.design.mated_distance] = 0
    unknown = seated < 0
    if unknown.any():
        exact = outcomes_at(atlas.design, xs[unknown], ts[unknown], atlas.physics)
        seated[unknown] = exact == Outcome.SEATED
    return seated


def _ray_masses(
    atlas: AcceptanceAtlas,
    mean: tuple[float, float],
    factor: FloatArray,
    seated_at_mean: bool,
    phi: FloatArray,
    n_r: int,
    crossing_steps: int,
    boundary: str,
) -> FloatArray:
    """The Gaussian's SEATED mass along each ray of direction ``phi`` (rad, in the whitened
    plane), ``n_r`` samples a ray: all rays' samples in one batch, then one batch per
    bisection step of their crossings (simulated, or with ``boundary="atlas"`` read from
    the atlas's straight boundaries where a cell has them)."""
    u = np.column_stack((np.cos(phi), np.sin(phi)))
    d = u @ factor.T  # pose change per unit radius, (rays, 2)
    r = np.linspace(0.0, RAY_RADIUS, n_r + 1)
    xs = mean[0] + r[None, :] * d[:, 0, None]
    ts = mean[1] + r[None, :] * d[:, 1, None]
    seated = _seated(atlas, xs, ts, boundary)
    seated[:, 0] = int(seated_at_mean)
    # Crossings between neighbouring samples, bisected (all rays at once).
    ray, k = np.nonzero(seated[:, :-1] != seated[:, 1:])
    crossing = np.broadcast_to(r[1:], seated[:, 1:].shape).copy()
    if ray.size:
        lo, hi = r[k].copy(), r[k + 1].copy()
        inner = seated[ray, k]
        for _ in range(crossing_steps):
            mid = 0.5 * (lo + hi)
            got = _seated(atlas, mean[0] + mid * d[ray, 0], mean[1] + mid * d[ray, 1], boundary)
            same = got == inner
            lo = np.where(same, mid, lo)
            hi = np.where(same, hi, mid)
        crossing[ray, k] = 0.5 * (lo + hi)
    tail_lo = _rayleigh_tail(np.broadcast_to(r[:-1], crossing.shape))
    tail_c = _rayleigh_tail(crossing)
    tail_hi = _rayleigh_tail(np.broadcast_to(r[1:], crossing.shape))
    mass = seated[:, :-1] * (tail_lo - tail_c) + seated[:, 1:] * (tail_c - tail_hi)
    return np.asarray(
        mass.sum(axis=1) + seated[:, -1] * _rayleigh_tail(np.array(RAY_RADIUS)), dtype=np.float64
    )


def _adaptive_in_angle(
    masses: Callable[[FloatArray], FloatArray], ray_tol: float
) -> tuple[float, int]:
    """The mean of ``masses`` over the circle by adaptive trapezoids, and the rays it took.

    ``FIRST_RAYS`` evenly spaced rays, then repeatedly, for every interval between two
    neighbouring rays at once, the ray through its middle: an interval whose trapezoid
    changes by more than ``ray_tol`` times its share of the circle when that ray is added is
    split in two (at most ``MAX_SPLITS`` times), the others count by Simpson's rule.
    The mass along a ray is a smooth function of its angle except where a ray grazes a
    boundary or passes a corner of the SEATED region; the splits gather there."""
    two_pi = 2.0 * math.pi
    start = two_pi * np.arange(FIRST_RAYS) / FIRST_RAYS
    width = np.full(FIRST_RAYS, two_pi / FIRST_RAYS)
    m_start = masses(start)
    m_end = np.roll(m_start, -1)
    rays, total = FIRST_RAYS, 0.0
    for depth in range(MAX_SPLITS + 1):
        middle = start + 0.5 * width
        m_mid = masses(middle)
        rays += middle.size
        coarse = width * (m_start + m_end) / 2.0
        fine = width * (m_start + 2.0 * m_mid + m_end) / 4.0
        split = np.abs(fine - coarse) > ray_tol * width / two_pi
        if depth == MAX_SPLITS:
            split[:] = False
        # Simpson's rule on the kept intervals (Richardson's extrapolation of the two
        # trapezoids): fourth order where the masses are smooth in angle, which uneven
        # trapezoids alone are not (even ones are, on a periodic function: over the 48
        # queries below, trapezoids alone had a median error of 2.0e-4, Simpson 4.7e-5).
        total += float((fine[~split] + (fine[~split] - coarse[~split]) / 3.0).sum())
        if not split.any():
            break
        start = np.concatenate((start[split], middle[split]))
        width = np.concatenate((width[split], width[split])) / 2.0
        m_start, m_end = (
            np.concatenate((m_start[split], m_mid[split])),
            np.concatenate((m_mid[split], m_end[split])),
        )
    return total / two_pi, rays


def _one_query(
    atlas: AcceptanceAtlas,
    mean: tuple[float, float],
    factor: FloatArray,
    seated_at_mean: bool,
    quadrature: tuple[int | None, float, int, str],
) -> float:
    """Seat probability of one query (pose in D and rad, ``factor`` A in D and rad);
    ``quadrature``: rays (None: adaptive in angle), ray tolerance, crossing steps, boundary."""
    if not factor.any():
        return 1.0 if seated_at_mean else 0.0
    rays, ray_tol, crossing_steps, boundary = quadrature
    n_r = _samples_per_ray(atlas, factor)

    def masses(phi: FloatArray) -> FloatArray:
        return _ray_masses(atlas, mean, factor, seated_at_mean, phi, n_r, crossing_steps, boundary)

    if rays is None:
        return _adaptive_in_angle(masses, ray_tol)[0]
    return float(masses(2.0 * math.pi * (np.arange(rays) + 0.5) / rays).mean())


def seat_probability(
    design: FaceDesign,
    x0: npt.ArrayLike,
    theta0: npt.ArrayLike,
    cov: npt.ArrayLike,
    *,
    physics: Physics | None = None,
    atlas: AcceptanceAtlas | None = None,
    rays: int | None = None,
    ray_tol: float = DEFAULT_RAY_TOL,
    crossing_steps: int = CROSSING_STEPS,
    boundary: str = "exact",
) -> float | FloatArray:
    """Probability that the dock seats when the true (x0, theta0) is Gaussian around the
    estimate, for one query or many.

    Parameters
    ----------
    design : FaceDesign
    x0, theta0 : float or array
        Estimated lateral offset (the design's length unit) and angle (rad); broadcast.
    cov : (2, 2) or (n, 2, 2) array
        Covariance of (x0, theta0): units length^2, length rad, rad^2; n of them for n poses
        (or for one pose: then one probability per covariance). Zero gives the exact
        prediction's outcome (1.0 or 0.0); a singular covariance (one direction certain) is
        accepted.
    physics : Physics, optional
        As for :func:`~xface_core.predict` (default ``Physics()``).
    atlas : AcceptanceAtlas, optional
        Built for this design and physics; default: one is built (seconds: pass it in to
        ask many questions).
    rays : int, optional
        Directions of the polar quadrature, evenly spaced (4 to 4096); default None: adaptive
        in angle, rays added where neighbouring rays' masses disagree (``ray_tol``).
    ray_tol : float
        The adaptive quadrature's split threshold (default 0.1; in (0, 1]): smaller is more
        rays and a smaller error (docs/atlas.md has the measured errors and times).
    crossing_steps : int
        Bisection steps of each boundary crossing along a ray (default 4: to 1/16 of the
        spacing of the ray's samples).
    boundary : {"exact", "atlas"}
        How a sample in an atlas cell with a boundary is decided (default ``"exact"``: by
        simulation); ``"atlas"``: by the straight boundary between the flips on the cell's
        edges, simulating only where none can be drawn, no simulation at all for most
        queries on an atlas built with ``every_flip`` (as the ROS node's is). Its error
        and speed against the exact boundary are measured in docs/atlas.md.

    Returns
    -------
    float or (n,) array
        A float when x0 and theta0 are scalars.

    Raises
    ------
    InputError
        A non-finite mean.
    XfaceValueError
        A covariance of the wrong shape, not symmetric or not positive semi-definite; an atlas
        for another design or physics.

    Examples
    --------
    >>> from xface_core import v_face
    >>> from xface_core.atlas.build import build_atlas
    >>> d = v_face(0.5, 1.0)
    >>> a = build_atlas(d, lateral_step=1 / 16, angle_step=0.05, angle_range=1.6)
    >>> seat_probability(d, 0.0, 0.0, [[0.0, 0.0], [0.0, 0.0]], atlas=a)
    1.0
    >>> 0.0 < seat_probability(d, 0.0, 0.0, [[0.04, 0.0], [0.0, 0.04]], atlas=a) < 1.0
    True
    """
    phys = Physics() if physics is None else physics
    if rays is not None and not is_integer_in(rays, 4, 4096):
        raise XfaceValueError(f"rays must be None or an integer in [4, 4096], got {rays!r}")
    if not is_positive_up_to(ray_tol, 1.0):
        raise XfaceValueError(f"ray_tol must be a number in (0, 1], got {ray_tol!r}")
    if boundary not in BOUNDARIES:
        raise XfaceValueError(f"boundary must be one of {BOUNDARIES}, got {boundary!r}")
    if not is_integer_in(crossing_steps, 0, 30):
        raise XfaceValueError(
            f"crossing_steps must be an integer in [0, 30], got {crossing_steps!r}"
        )
    xb, tb = np.broadcast_arrays(
        np.asarray(x0, dtype=np.float64), np.asarray(theta0, dtype=np.float64)
    )
    scalar = xb.ndim == 0 and np.ndim(cov) == 2
    if scalar or np.ndim(cov) != 3:
        xs, ts = xb.ravel(), tb.ravel()
    else:  # one pose, many covariances: the pose repeats
        n = np.shape(cov)[0]
        xs, ts = np.broadcast_to(xb.ravel(), (n,)), np.broadcast_to(tb.ravel(), (n,))
        xb = xs
    if not (np.isfinite(xs).all() and np.isfinite(ts).all()):
        raise InputError("x0 and theta0 must be finite")
    cov_c = checked_covariances(cov, xs.size)
    at = build_atlas(design, physics=phys) if atlas is None else atlas
    at = at.bound_to(design, phys)
    w = design.width
    # Covariance in (D, rad): x scales by 1/w.
    scale = np.array([1.0 / w, 1.0])
    factors = pose_factors(cov_c * scale[None, :, None] * scale[None, None, :])
    at_mean = outcomes_at(design, np.asarray(xs, dtype=np.float64) / w, ts, phys)
    bad = at_mean == Outcome.INVALID_INPUT
    if bad.any():
        raise InputError(f"the pose ({xs[bad][0]!r}, {ts[bad][0]!r}) cannot be simulated")
    out = np.array(
        [
            _one_query(
                at,
                (xs[n] / w, ts[n]),
                factors[n],
                bool(at_mean[n] == Outcome.SEATED),
                (rays, float(ray_tol), crossing_steps, boundary),
            )
            for n in range(xs.size)
        ]
    )
    return float(out[0]) if scalar else out.reshape(xb.shape)
