"""The quasi-static Coulomb contact problem at a state, solved on its own by enumeration.

Evidence for docs/contact.md ("Two-contact Coulomb wedges, solved independently"). Run from the
repository root (a few seconds)::

    .venv/bin/python scripts/evidence/two_contact_coulomb.py

xface ends three kinds of cells "jammed by friction" (BAD_MATE) where Chipmunk2D seats (issue 37).
This script takes the state where xface stops (``xface_core.predict`` gives the path and the final
angles; nothing of the engine's contact mechanics is used: no ``xface_core.contact``, nothing under
``xface_core/_engine``), finds the touching vertex-edge pairs from the outlines alone, and solves
the rigid quasi-static problem there:

- unknowns: the rates ``w_B = dphi_B/ds``, ``w_M = dphi_M/ds`` (rad per D of descent ``s``) and
  each contact's normal force ``lam`` and tangential (friction) force ``f`` (in units of
  ``c_M x 1 rad/D x (D / unit time)``: only ratios of forces matter);
- the moving pivot is driven: ``dy_M/ds = -1``, ``x_M`` fixed. Its reaction (the drive and the
  rail) is whatever is needed, so it has no moment about the moving pivot and does not enter the
  two moment balances; it is reported (``drive``: the force the drive puts on the moving part
  along +y, negative when it pushes the part toward the base);
- the moment balance of each part about its own pivot: the contact forces' moments equal the
  damper's ``c w`` (docs/model.md: rotational dampers c_B, c_M; only c_B / c_M matters, ``inf``
  holds the base; the descent is the clock, so the damper torque is ``c dphi/ds`` per unit
  driving speed);
- per contact, Coulomb complementarity, enumerated as four modes: ``sep`` (lam = f = 0, gap rate
  >= 0), ``stick`` (gap rate 0, slip rate 0, |f| <= mu lam), ``slide+`` / ``slide-`` (gap rate
  0, slip rate >= 0 / <= 0, f = -+ mu lam, lam >= 0).

Every combination of modes is a linear system with linear inequalities; each is solved exactly
(least squares with a consistency check, then a vertex search over its null space when the
system is indeterminate, e.g. a stuck contact beside a sliding one), and the combinations that
satisfy all inequalities are the admissible motions. None admissible: the rigid model is wedged.
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from xface_core import predict
from xface_core.geometry import FaceDesign, v_face, x_face

FloatArray = npt.NDArray[np.float64]

#: A pair touches when its gap is below this (D), as in the brief and xface's CORNER_REACH.
TOUCH_GAP = 1e-7
#: Inequalities and consistency are judged to this, relative to the solution's own size.
REL_TOL = 1e-9
MODES = ("sep", "stick", "slide+", "slide-")


@dataclass(frozen=True)
class State:
    """A configuration: base angle, moving angle (rad), moving pivot (x0, y_m) in D."""

    phi_b: float
    phi_m: float
    x0: float
    y_m: float


@dataclass(frozen=True)
class Contact:
    """A vertex of one part touching an edge of the other, in the world frame (units of D).

    ``normal`` is the edge's outward unit normal (out of the edge's part, into the vertex's
    part); ``tangent`` the edge's direction (its start to its end); ``u`` where the vertex
    projects along the edge (0, 1: the ends); ``end_distance`` its distance to the nearer end.
    """

    label: str
    vertex_part: str  # "base" or "moving"
    point: tuple[float, float]
    normal: tuple[float, float]
    tangent: tuple[float, float]
    gap: float = 0.0
    u: float = 0.5
    end_distance: float = math.inf
    #: Where the pair is on the outlines (layer, vertex index, edge index), -1 for hand-made
    #: contacts: :func:`pair_gap` follows the same pair to other states.
    layer: int = -1
    vertex: int = -1
    edge: int = -1


@dataclass(frozen=True)
class Motion:
    """One admissible mode combination: rates, forces and what each contact does."""

    modes: tuple[str, ...]
    w_b: float
    w_m: float
    lam: tuple[float, ...]
    friction: tuple[float, ...]
    gap_rate: tuple[float, ...]
    slip_rate: tuple[float, ...]
    drive: float
    family_dim: int  # dimension of the solution set of this mode (0: unique)


def _cross(a: FloatArray, b: FloatArray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def _perp(a: FloatArray) -> FloatArray:
    return np.array([-a[1], a[0]])


def find_contacts(design: FaceDesign, state: State, touch: float = TOUCH_GAP) -> list[Contact]:
    """Every vertex-edge pair of one layer closer than ``touch`` (D) to touching, from outlines.

    A pair is a vertex of one part against an edge of the other in the same layer; its gap is
    the vertex's signed distance from the edge's line along the outward normal (outlines are
    counter-clockwise), counted only where the vertex projects within the edge (``touch`` of
    slack at the ends).
    """
    found: list[Contact] = []
    for layer in range(design.n_layers):
        base = design.base_outline_world(layer, state.phi_b)
        moving = design.moving_outline_world(layer, state.x0, state.y_m, state.phi_m)
        for vpart, verts, epart, poly in (
            ("moving", moving, "base", base),
            ("base", base, "moving", moving),
        ):
            for j in range(len(poly)):
                a, b = poly[j], poly[(j + 1) % len(poly)]
                length = float(np.hypot(*(b - a)))
                t = (b - a) / length
                n = np.array([t[1], -t[0]])  # outward for a counter-clockwise outline
                for i, v in enumerate(verts):
                    along = float(np.dot(v - a, t))
                    gap = float(np.dot(v - a, n))
                    if abs(gap) < touch and -touch <= along <= length + touch:
                        found.append(
                            Contact(
                                label=f"L{layer} {vpart} v{i} on {epart} e{j}",
                                vertex_part=vpart,
                                point=(float(v[0]), float(v[1])),
                                normal=(float(n[0]), float(n[1])),
                                tangent=(float(t[0]), float(t[1])),
                                gap=gap,
                                u=along / length,
                                end_distance=min(abs(along), abs(length - along)),
                                layer=layer,
                                vertex=i,
                                edge=j,
                            )
                        )
    return found


def contact_kinematics(
    contact: Contact, state: State
) -> tuple[FloatArray, float, FloatArray, float, FloatArray, FloatArray]:
    """Rates and generalised forces of one contact, all linear in (w_B, w_M).

    Returns ``(gn, gn0, gt, gt0, qn, qt)``: gap rate ``gn . w + gn0`` and slip rate
    ``gt . w + gt0`` (the vertex part's point relative to the edge part's coincident point,
    along the normal and the tangent; the pivot descends at unit speed), and the moments
    ``qn`` (base, moving) that a unit normal force and ``qt`` a unit tangential force on the
    vertex's part (its reaction on the edge's part) exert about the two pivots.
    """
    p = np.array(contact.point)
    n, t = np.array(contact.normal), np.array(contact.tangent)
    pivot_m = np.array([state.x0, state.y_m])
    # velocity of the material point at p: base w_B perp(p); moving (0, -1) + w_M perp(p - P_M)
    jac_b, jac_m = _perp(p), _perp(p - pivot_m)
    drift_m = np.array([0.0, -1.0])
    sign = 1.0 if contact.vertex_part == "moving" else -1.0  # vertex part minus edge part
    jac = np.column_stack((-sign * jac_b, sign * jac_m))  # d v_rel / d (w_B, w_M)
    drift = sign * drift_m
    gn, gt = n @ jac, t @ jac
    gn0, gt0 = float(n @ drift), float(t @ drift)
    # force F on the vertex part, -F on the edge part: moments about each pivot
    qn = np.array([-sign * _cross(p, n), sign * _cross(p - pivot_m, n)])
    qt = np.array([-sign * _cross(p, t), sign * _cross(p - pivot_m, t)])
    return gn, gn0, gt, gt0, qn, qt


def _feasible_point(
    a_eq: FloatArray, b_eq: FloatArray, g_in: FloatArray, h_in: FloatArray, scale: float
) -> tuple[FloatArray | None, int]:
    """A point of {z : a_eq z = b_eq, g_in z >= h_in} and the dimension of the equality set.

    Exact for small systems: least squares, a consistency check, then, on the null space,
    a vertex search (every square subsystem of the inequalities, tight) after removing the
    directions no inequality sees. Returns (None, dim) when empty.
    """
    z0: FloatArray = np.linalg.lstsq(a_eq, b_eq, rcond=None)[0].astype(np.float64)
    tol = REL_TOL * max(scale, float(np.abs(z0).max(initial=0.0)), 1.0)
    if np.abs(a_eq @ z0 - b_eq).max(initial=0.0) > tol * 1e3:
        return None, -1  # the equalities contradict each other
    _, sing, vt = np.linalg.svd(a_eq)
    rank = int((sing > 1e-10 * max(sing.max(initial=0.0), 1.0)).sum())
    null = vt[rank:].T
    dim = null.shape[1]

    def ok(z: FloatArray) -> bool:
        slack_tol = REL_TOL * max(scale, float(np.abs(z).max(initial=0.0)), 1.0) * 1e3
        # Each equality to its own scale too (its backward error): where the balance is
        # singular (a pole of the forces), a point far along a direction that is null only to
        # round-off met the global tolerance with a gap rate of -0.54.
        row_tol = REL_TOL * 1e3 * (np.abs(a_eq) @ np.abs(z) + np.abs(b_eq) + 1.0)
        return bool(
            np.all(g_in @ z - h_in >= -slack_tol) and np.all(np.abs(a_eq @ z - b_eq) <= row_tol)
        )

    if dim == 0 or len(h_in) == 0:
        return (z0 if ok(z0) else None), dim
    m, h = g_in @ null, h_in - g_in @ z0
    _, ms, mvt = np.linalg.svd(m)
    mrank = int((ms > 1e-10 * max(ms.max(initial=0.0), 1.0)).sum())
    if mrank == 0:
        return (z0 if ok(z0) else None), dim
    basis = mvt[:mrank].T  # directions of the null space the inequalities see
    mb = m @ basis
    for rows in itertools.combinations(range(len(h)), mrank):
        sub = mb[list(rows)]
        if abs(np.linalg.det(sub)) < 1e-12 * max(np.abs(sub).max(), 1.0) ** mrank:
            continue
        z = z0 + null @ (basis @ np.linalg.solve(sub, h[list(rows)]))
        if ok(z):
            return z, dim
    return None, dim


def _mode_system(
    kin: list[tuple[FloatArray, float, FloatArray, float, FloatArray, FloatArray]],
    modes: tuple[str, ...],
    mu: float,
    damping_ratio: float,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, list[str]]:
    """Equalities and inequalities of one mode combination; z = (w_B, w_M, lam_i, f_i ...).

    The last item names each inequality (``gdot1 >= 0``, ``lam2 >= 0``, ...), for reports.
    """
    k = len(kin)
    size = 2 + 2 * k
    eq: list[tuple[FloatArray, float]] = []
    ineq: list[tuple[FloatArray, float]] = []
    names: list[str] = []
    # moment balance about each pivot: sum of contact moments - c w = 0 (c_M = 1)
    for body in (0, 1):
        row = np.zeros(size)
        if body == 0 and math.isinf(damping_ratio):
            row[0] = 1.0  # the base is held: w_B = 0, its balance is the support's business
            eq.append((row, 0.0))
            continue
        row[body] = -(damping_ratio if body == 0 else 1.0)
        for i, (_, _, _, _, qn, qt) in enumerate(kin):
            row[2 + 2 * i], row[3 + 2 * i] = qn[body], qt[body]
        eq.append((row, 0.0))
    for i, ((gn, gn0, gt, gt0, _, _), mode) in enumerate(zip(kin, modes, strict=True)):
        li, fi = 2 + 2 * i, 3 + 2 * i
        gap_row, slip_row = np.zeros(size), np.zeros(size)
        gap_row[:2], slip_row[:2] = gn, gt
        lam_row, f_row = np.zeros(size), np.zeros(size)
        lam_row[li], f_row[fi] = 1.0, 1.0
        if mode == "sep":
            eq += [(lam_row, 0.0), (f_row, 0.0)]
            ineq.append((gap_row, -gn0))
            names.append(f"gdot{i + 1} >= 0")
            continue
        eq.append((gap_row, -gn0))
        ineq.append((lam_row, 0.0))
        names.append(f"lam{i + 1} >= 0")
        if mode == "stick":
            eq.append((slip_row, -gt0))
            ineq += [(mu * lam_row - f_row, 0.0), (mu * lam_row + f_row, 0.0)]
            names += [f"f{i + 1} <= mu lam{i + 1}", f"f{i + 1} >= -mu lam{i + 1}"]
        else:
            sign = 1.0 if mode == "slide+" else -1.0
            eq.append((f_row + sign * mu * lam_row, 0.0))  # friction opposes the slip
            ineq.append((sign * slip_row, -sign * gt0))
            names.append(f"slip{i + 1} {'>=' if sign > 0 else '<='} 0")
    a_eq = np.array([r for r, _ in eq])
    b_eq = np.array([v for _, v in eq])
    g_in = np.array([r for r, _ in ineq]) if ineq else np.zeros((0, size))
    h_in = np.array([v for _, v in ineq])
    return a_eq, b_eq, g_in, h_in, names


def admissible_motions(
    contacts: list[Contact], state: State, mu: float, damping_ratio: float = 1.0
) -> list[Motion]:
    """Every mode combination (sep / stick / slide+ / slide- per contact) that is admissible.

    ``damping_ratio`` = c_B / c_M (``inf`` holds the base). An empty list: no rigid
    quasi-static motion with Coulomb friction descends from this state (a wedge).
    """
    kin = [contact_kinematics(c, state) for c in contacts]
    scale = 1.0 + sum(float(np.abs(np.r_[g[0], g[2], g[4], g[5]]).max()) for g in kin)
    found: list[Motion] = []
    for modes in itertools.product(MODES, repeat=len(contacts)):
        a_eq, b_eq, g_in, h_in, _ = _mode_system(kin, modes, mu, damping_ratio)
        z, dim = _feasible_point(a_eq, b_eq, g_in, h_in, scale)
        if z is None:
            continue
        w = z[:2]
        lam, fric = z[2::2], z[3::2]
        drive_y = 0.0  # drive force on the moving part, +y; minus the contacts' y force on it
        for c, li, fi in zip(contacts, lam, fric, strict=True):
            force = li * np.array(c.normal) + fi * np.array(c.tangent)
            drive_y -= float(force[1]) if c.vertex_part == "moving" else -float(force[1])
        found.append(
            Motion(
                modes=modes,
                w_b=float(w[0]),
                w_m=float(w[1]),
                lam=tuple(float(x) for x in lam),
                friction=tuple(float(x) for x in fric),
                gap_rate=tuple(float(g[0] @ w + g[1]) for g in kin),
                slip_rate=tuple(float(g[2] @ w + g[3]) for g in kin),
                drive=drive_y,
                family_dim=dim,
            )
        )
    return found


def why_not(
    contacts: list[Contact], state: State, mu: float, damping_ratio: float = 1.0
) -> list[str]:
    """Per mode combination, why it is not admissible: its equalities contradict each other
    (kinematically impossible), or their solution (when unique) breaks named inequalities."""
    kin = [contact_kinematics(c, state) for c in contacts]
    lines = []
    for modes in itertools.product(MODES, repeat=len(contacts)):
        a_eq, b_eq, g_in, h_in, names = _mode_system(kin, modes, mu, damping_ratio)
        z, *_ = np.linalg.lstsq(a_eq, b_eq, rcond=None)
        head = f"    {' / '.join(modes):<22}"
        if np.abs(a_eq @ z - b_eq).max() > 1e-6 * max(1.0, float(np.abs(z).max())):
            lines.append(f"{head} equalities contradict: kinematically impossible")
            continue
        if np.linalg.matrix_rank(a_eq) < a_eq.shape[1]:
            lines.append(f"{head} indeterminate forces (see the admissible list)")
            continue
        slack = g_in @ z - h_in
        broken = [
            f"{n} ({v:+.3g})"
            for n, v in zip(names, slack, strict=True)
            if v < -1e-9 * max(1.0, float(np.abs(z).max()))
        ]
        state_txt = f"w ({z[0]:+.3f}, {z[1]:+.3f}) lam ({', '.join(f'{x:+.4g}' for x in z[2::2])})"
        lines.append(
            f"{head} {state_txt}: {'breaks ' + ', '.join(broken) if broken else 'admissible'}"
        )
    return lines


def distinct_rates(motions: list[Motion], tol: float = 1e-7) -> list[tuple[float, float]]:
    """The different rate pairs (w_B, w_M) among ``motions`` (mode combinations that describe
    one motion, e.g. a separating contact whose gap rate is zero, count once)."""
    rates: list[tuple[float, float]] = []
    for m in motions:
        if not any(
            abs(m.w_b - a) <= tol * (1 + abs(a)) and abs(m.w_m - b) <= tol * (1 + abs(b))
            for a, b in rates
        ):
            rates.append((m.w_b, m.w_m))
    return rates


def critical_friction(
    contacts: list[Contact], state: State, damping_ratio: float, hi: float, steps: int = 40
) -> float | None:
    """The friction coefficient above which no motion is admissible (bisection on [0, hi]).

    None when a motion is admissible at ``hi`` too (no wedge up to hi). Assumes admissibility
    is lost once for good on [0, hi]; the script prints the motions on both sides.
    """
    if admissible_motions(contacts, state, hi, damping_ratio):
        return None
    lo = 0.0
    if not admissible_motions(contacts, state, lo, damping_ratio):
        return 0.0
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        if admissible_motions(contacts, state, mid, damping_ratio):
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def pair_gap(design: FaceDesign, state: State, contact: Contact) -> float:
    """The signed gap (D) of ``contact``'s vertex-edge pair (found by :func:`find_contacts`)
    at ``state``: the vertex's distance from the edge's line along its outward normal."""
    base = design.base_outline_world(contact.layer, state.phi_b)
    moving = design.moving_outline_world(contact.layer, state.x0, state.y_m, state.phi_m)
    verts, poly = (moving, base) if contact.vertex_part == "moving" else (base, moving)
    a, b = poly[contact.edge], poly[(contact.edge + 1) % len(poly)]
    t = (b - a) / float(np.hypot(*(b - a)))
    return float(np.dot(verts[contact.vertex] - a, np.array([t[1], -t[0]])))


def on_contacts(
    design: FaceDesign, contacts: list[Contact], state: State, y_m: float
) -> tuple[State, float]:
    """The state at pivot height ``y_m`` (D) where every pair of ``contacts`` still touches.

    Gauss-Newton on the two angles from ``state`` (least squares: the pairs of two flush
    edges are dependent), with a forward-difference Jacobian (1e-7 rad). Returns the state and
    the largest gap left (D), which says whether the pairs can all touch there.
    """
    z = np.array([state.phi_b, state.phi_m])

    def gaps(angles: FloatArray) -> FloatArray:
        here = State(float(angles[0]), float(angles[1]), state.x0, y_m)
        return np.array([pair_gap(design, here, c) for c in contacts])

    for _ in range(60):
        g = gaps(z)
        jac = np.column_stack([(gaps(z + 1e-7 * e) - g) / 1e-7 for e in np.eye(2)])
        step = np.linalg.lstsq(jac, -g, rcond=None)[0]
        z = z + step
        if np.abs(step).max() < 1e-15:
            break
    return State(float(z[0]), float(z[1]), state.x0, y_m), float(np.abs(gaps(z)).max())


#: Distances (D of descent) either side of a stop where :func:`rigid_stop` looks for a pole.
POLE_DISTANCES = (1e-4, 1e-5, 1e-6)
#: The drive times the distance to the stop, at the three distances, within this ratio of
#: each other: the drive grows as 1 / distance (a simple pole at the stop).
POLE_SPREAD = 1.1


@dataclass(frozen=True)
class RigidStop:
    """What the rigid quasi-static model with Coulomb friction does at a stop of xface.

    ``kind``: ``"wedge"``, no motion is admissible at the stop; ``"pole"``, one motion is
    admissible on the stop's contacts up to it, with a pushing drive that grows as
    ``pole / distance``, and none just past it (a drive of finite force stalls before the
    stop, one of infinite force cannot pass it); ``""``, neither is shown (``detail`` says
    why). ``critical_mu``: for a wedge, the friction coefficient below which a motion is
    admissible at the stop.
    """

    kind: str
    contacts: int
    critical_mu: float | None
    pole: float | None
    detail: str


def _pair_keys(contacts: list[Contact]) -> set[tuple[int, str, int, int]]:
    return {(c.layer, c.vertex_part, c.vertex, c.edge) for c in contacts}


def same_contacts_at(
    design: FaceDesign, contacts: list[Contact], state: State, y_m: float
) -> tuple[State, list[Contact]] | None:
    """The state at pivot height ``y_m`` on ``contacts`` (:func:`on_contacts`) with the
    touching pairs found there again from the outlines, or None when those are not exactly
    the pairs of ``contacts`` (they cannot all touch there, to 1e-3 of TOUCH_GAP, or another
    pair does)."""
    here, left = on_contacts(design, contacts, state, y_m)
    found = find_contacts(design, here)
    if left > 1e-3 * TOUCH_GAP or _pair_keys(found) != _pair_keys(contacts):
        return None
    return here, found


def _pole(
    design: FaceDesign, contacts: list[Contact], state: State, mu: float, damping_ratio: float
) -> tuple[float | None, str]:
    """``(c, "")`` when the drive grows as ``c / distance`` up to ``state`` on its contacts
    and no motion is admissible past it, else ``(None, why not)``."""
    products = []
    for dist in POLE_DISTANCES:
        for side in (1.0, -1.0):
            where = f"{dist:g} D {'before' if side > 0 else 'past'} the stop"
            followed = same_contacts_at(design, contacts, state, state.y_m + side * dist)
            if followed is None:
                return None, f"other contacts {where}"
            here, found = followed
            motions = admissible_motions(found, here, mu, damping_ratio)
            if side < 0:
                if motions:
                    return None, f"a motion is admissible {where}"
                continue
            if len(distinct_rates(motions)) != 1 or any(m.drive >= 0 for m in motions):
                return None, f"not one pushing motion {where}"
            products.append(max(-m.drive for m in motions) * dist)
    if max(products) > POLE_SPREAD * min(products):
        return None, "the drive does not grow as 1 / distance"
    return float(np.mean(products)), ""


def rigid_stop(design: FaceDesign, state: State, mu: float, damping_ratio: float) -> RigidStop:
    """Whether the rigid model stops at ``state`` too: a pole of the drive there, or a wedge.

    The pole test (first: at a pole the balance at the stop itself is singular, and no motion
    is admissible there either) follows the stop's contacts (:func:`on_contacts`) to
    :data:`POLE_DISTANCES` before and past the stop, finds the touching pairs again there
    from the outlines, and asks for the same pairs, one pushing motion before (the drive
    times the distance constant within :data:`POLE_SPREAD`) and no admissible motion past.
    Else a wedge is a stop where no motion is admissible (typically where a contact arrived:
    the pairs before it are others).
    """
    contacts = find_contacts(design, state)
    k = len(contacts)
    if not contacts:
        return RigidStop("", 0, None, None, "no contact at the stop")
    pole, why_not = _pole(design, contacts, state, mu, damping_ratio)
    if pole is not None:
        detail = f"{k} contacts, drive {-pole:.3g} / distance before the stop, no motion past it"
        return RigidStop("pole", k, None, pole, detail)
    # None: a motion is admissible at the stop, at mu itself.
    crit = critical_friction(contacts, state, damping_ratio, hi=mu)
    if crit is not None:
        return RigidStop(
            "wedge", k, crit, None, f"{k} contacts, no motion; motions below mu {crit:.4f}"
        )
    return RigidStop("", k, None, None, why_not)


@dataclass(frozen=True)
class Case:
    """A cell xface ends "jammed by friction" where Chipmunk2D seats (issue 37)."""

    name: str
    design: FaceDesign
    x0: float
    theta0: float
    mu: float
    lower_mu: float  # a smaller friction coefficient to solve the same state at


CASES = (
    Case(
        "V 0.32988/2 mu 0.2 (+0.40, -0.1571)", v_face(0.32988, 2.0), 0.4, -math.pi / 20, 0.2, 0.15
    ),
    Case("X 1/3 mu 0.3 (-0.70, +0.3142)", x_face(1.0, 3.0), -0.7, math.pi / 10, 0.3, 0.28),
    Case("X 1/3 mu 0.3 (+0.70, -0.3142)", x_face(1.0, 3.0), 0.7, -math.pi / 10, 0.3, 0.28),
    Case("X 0.0625/1 mu 0.3 (+0.35, -0.3142)", x_face(0.0625, 1.0), 0.35, -math.pi / 10, 0.3, 0.05),
    Case("X 0.0625/1 mu 0.3 (-0.35, +0.3142)", x_face(0.0625, 1.0), -0.35, math.pi / 10, 0.3, 0.05),
    Case(
        "X 0.0625/1 mu 0.3 (+0.25, -0.2356)", x_face(0.0625, 1.0), 0.25, -0.075 * math.pi, 0.3, 0.05
    ),
    Case(
        "X 0.0625/1 mu 0.3 (-0.25, +0.2356)", x_face(0.0625, 1.0), -0.25, 0.075 * math.pi, 0.3, 0.05
    ),
)


def xface_stop(case: Case, damping_ratio: float) -> tuple[str, State, State, float]:
    """xface's outcome, its final state, its last path sample before the stop (an accepted
    step or event, so on the path to the engine's tolerances) and the descent between them (D)."""
    p = predict(case.design, case.x0, case.theta0, friction=case.mu, damping_ratio=damping_ratio)
    assert p.path is not None
    path = p.path
    final = State(p.phi_b, p.phi_m, case.x0, p.pivot_m[1])
    s_end = float(path.descent[-1])
    i = int(np.flatnonzero(path.descent < s_end)[-1])
    before = State(float(path.phi_b[i]), float(path.phi_m[i]), case.x0, float(path.pivot_m[i, 1]))
    return f"{p.outcome.name} ({p.reason})", final, before, s_end - float(path.descent[i])


def pair_gap_and_rate(
    design: FaceDesign, state: State, label: str, w_b: float, w_m: float
) -> tuple[float, float]:
    """The gap (D) of the pair called ``label`` at ``state`` and its rate under (w_B, w_M)."""
    (pair,) = [c for c in find_contacts(design, state, touch=0.5) if c.label == label]
    gn, gn0, *_ = contact_kinematics(pair, state)
    return pair.gap, float(gn @ np.array([w_b, w_m]) + gn0)


def describe(motions: list[Motion], contacts: list[Contact]) -> list[str]:
    """Lines for a table: one per admissible mode combination, or the wedge."""
    if not motions:
        return ["    none: a wedge (no mode combination is admissible)"]
    lines = []
    for m in motions:
        per = ", ".join(
            f"{mode} lam {lam:+.4g} f {f:+.4g} gdot {g:+.3g} slip {s:+.3g}"
            for mode, lam, f, g, s in zip(
                m.modes, m.lam, m.friction, m.gap_rate, m.slip_rate, strict=True
            )
        )
        fam = (
            "" if m.family_dim == 0 else f" (forces: a {m.family_dim}-parameter family, one shown)"
        )
        lines.append(f"    w_B {m.w_b:+.5f} w_M {m.w_m:+.5f} drive {m.drive:+.4g}: {per}{fam}")
    lines.append(
        f"    {len(distinct_rates(motions))} distinct motion(s) of {len(motions)} combination(s)"
    )
    return lines


def report(case: Case, damping_ratio: float, explain: bool = False) -> list[str]:
    """The case taken apart: xface's stop, the contacts, the motions at mu and at a lower mu,
    the friction coefficient where motion stops, and the path just before the stop."""
    outcome, final, before, back = xface_stop(case, damping_ratio)
    contacts = find_contacts(case.design, final)
    out = [
        f"== {case.name}: xface {outcome}",
        f"  stop: phi_B {final.phi_b:+.9f} phi_M {final.phi_m:+.9f} y_M {final.y_m:.9f}",
    ]
    for c in contacts:
        out.append(
            f"  contact {c.label}: p ({c.point[0]:+.6f}, {c.point[1]:+.6f}) n ({c.normal[0]:+.4f},"
            f" {c.normal[1]:+.4f}) gap {c.gap:+.1e} u {c.u:.4f} end {c.end_distance:.2e}"
        )
    for mu, what in ((case.mu, "at the stop"), (case.lower_mu, "at the stop, lower mu")):
        out.append(f"  {what}, mu {mu}:")
        out += describe(admissible_motions(contacts, final, mu, damping_ratio), contacts)
        if explain:
            out += why_not(contacts, final, mu, damping_ratio)
    lower = predict(
        case.design, case.x0, case.theta0, friction=case.lower_mu, damping_ratio=damping_ratio
    )
    out.append(f"  xface from the same start at mu {case.lower_mu}: {lower.outcome.name}")
    crit = critical_friction(contacts, final, damping_ratio, hi=case.mu)
    out.append(
        f"  at the stop: motions admissible up to mu = {crit if crit is None else f'{crit:.4f}'}"
    )
    near = find_contacts(case.design, before)
    out.append(
        f"  {back:.4f} D before (xface's previous path sample; phi_B {before.phi_b:+.6f} phi_M"
        f" {before.phi_m:+.6f} y_M {before.y_m:.6f}), mu {case.mu}: {[c.label for c in near]}"
    )
    motions = admissible_motions(near, before, case.mu, damping_ratio)
    out += describe(motions, near)
    labels = {c.label for c in near}
    for c in contacts:
        if c.label not in labels and len(distinct_rates(motions)) == 1:
            gap, rate = pair_gap_and_rate(
                case.design, before, c.label, motions[0].w_b, motions[0].w_m
            )
            out.append(
                f"    arriving {c.label}: gap {gap:+.3e} D closing at {rate:+.3f} D/D"
                f" (closes in ~{-gap / rate if rate < 0 else math.inf:.4f} D of descent)"
            )
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--damping-ratio", type=float, default=1.0, help="c_B / c_M (default 1)")
    parser.add_argument(
        "--explain", action="store_true", help="say why each mode combination at the stop fails"
    )
    args = parser.parse_args(argv)
    for case in CASES:
        print("\n".join(report(case, args.damping_ratio, args.explain)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
