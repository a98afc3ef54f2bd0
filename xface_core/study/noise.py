"""Mean seat probability of a design over a pose grid, under Gaussian pose noise.

The question: the robot aims at a grid pose (x0, theta0), but its pose is only known up to
independent Gaussian errors of standard deviations ``sigma_x`` (D) and ``sigma_theta``
(rad). The *seat probability* of the aimed pose is the probability that the true pose
N((x0, theta0), diag(sigma_x^2, sigma_theta^2)) seats; the *mean seat probability* of a
design is its average over the grid's nodes.

It is estimated by Monte Carlo, not approximated from the grid's outcomes: each node draws
``samples`` true poses and every one is simulated. (A Gaussian-weighted fraction of SEATED
neighbours on the grid would be a quadrature of a step function at the grid's spacing,
blind to anything between the nodes.) The draws come from a seeded generator and are the
same for every design of a study (common random numbers: differences between designs are
not drowned in sampling noise), so the estimate is reproducible bit for bit. Its standard
error, ``sqrt(sum_i p_i (1 - p_i) / (n - 1)) / N`` over the N nodes' estimates p_i of n
draws each, is reported beside it: it measures the sampling error only (the grid itself is
the population averaged over).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import NamedTuple, cast

import numpy as np

from xface_core.codes import Outcome
from xface_core.errors import XfaceValueError, is_integer_in, is_positive_up_to
from xface_core.geometry import FaceDesign
from xface_core.maps.grids import ThetaGridKind, theta_grid, x0_grid
from xface_core.physics import Physics
from xface_core.runner import predict_batch

__all__ = ["MAX_NOISE_SAMPLES", "PoseNoise", "SeatProbability", "mean_seat_probability"]

#: Most noisy draws per grid node (each is one simulation).
MAX_NOISE_SAMPLES = 4096

#: Largest accepted standard deviations: beyond one width or 45 degrees the aimed pose says
#: little about the true one, and draws land far outside the grid.
MAX_SIGMA_X = 1.0
MAX_SIGMA_THETA = math.pi / 4


@dataclass(frozen=True)
class PoseNoise:
    """Independent Gaussian errors of the lateral offset (D) and the angle (rad), and how
    many draws per grid node estimate the seat probability (from generator ``seed``).

    Examples
    --------
    >>> PoseNoise(sigma_x=0.05, sigma_theta=0.02).samples
    16
    >>> PoseNoise(sigma_x=0.0, sigma_theta=0.02)
    Traceback (most recent call last):
    ...
    xface_core.errors.XfaceValueError: sigma_x must be in (0, 1] D, got 0.0
    """

    sigma_x: float
    sigma_theta: float
    samples: int = 16
    seed: int = 0

    def __post_init__(self) -> None:
        for name, top, unit in (
            ("sigma_x", MAX_SIGMA_X, "D"),
            ("sigma_theta", MAX_SIGMA_THETA, "rad"),
        ):
            value = getattr(self, name)
            if not is_positive_up_to(value, top):
                raise XfaceValueError(f"{name} must be in (0, {top:.4g}] {unit}, got {value!r}")
        samples, seed = cast(object, self.samples), cast(object, self.seed)
        if not is_integer_in(samples, 2, MAX_NOISE_SAMPLES):
            raise XfaceValueError(
                f"noise samples must be an integer in [2, {MAX_NOISE_SAMPLES}], got {samples!r}"
            )
        if not is_integer_in(seed, 0, 2**63 - 1):
            raise XfaceValueError(f"noise seed must be an integer >= 0, got {seed!r}")
        # Normalise ints (a CLI "1") so equal noise compares and hashes equal.
        object.__setattr__(self, "sigma_x", float(self.sigma_x))
        object.__setattr__(self, "sigma_theta", float(self.sigma_theta))

    def as_dict(self) -> dict[str, float | int]:
        """The four fields (stored with a study's settings)."""
        return asdict(self)


class SeatProbability(NamedTuple):
    """The grid mean of the seat probability and the standard error of its estimate."""

    mean: float
    standard_error: float


def mean_seat_probability(
    design: FaceDesign,
    noise: PoseNoise,
    *,
    grid: int,
    theta_kind: ThetaGridKind = "symmetric",
    physics: Physics,
) -> SeatProbability:
    """The mean over the ``grid x grid`` nodes of the probability that a pose drawn from
    N(node, diag(sigma_x^2, sigma_theta^2)) seats, by Monte Carlo (see the module).

    Runs on one thread. Examples
    --------
    >>> from xface_core import x_face
    >>> p = mean_seat_probability(
    ...     x_face(0.5, 1.0), PoseNoise(0.05, 0.05), grid=5, physics=Physics()
    ... )
    >>> 0.0 < p.mean < 1.0, 0.0 < p.standard_error < 0.1
    (True, True)
    """
    x = x0_grid(grid)
    th = theta_grid(grid, theta_kind)
    X, T = np.meshgrid(x, th, indexing="ij")
    rng = np.random.default_rng(noise.seed)
    shape = (X.size, noise.samples)
    dx = rng.standard_normal(shape) * noise.sigma_x
    dth = rng.standard_normal(shape) * noise.sigma_theta
    # Unit width: x0 in D, like the grid.
    runs = predict_batch(
        design.with_width(1.0),
        X.reshape(-1, 1) + dx,
        T.reshape(-1, 1) + dth,
        physics=physics,
        threads=1,
    )
    p_node = (runs.outcome == Outcome.SEATED).mean(axis=1)
    n = noise.samples
    se = math.sqrt(float(np.sum(p_node * (1.0 - p_node))) / (n - 1)) / p_node.size
    return SeatProbability(float(p_node.mean()), se)
