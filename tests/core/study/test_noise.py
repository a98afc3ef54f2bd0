"""Mean seat probability under pose noise: a Monte Carlo estimate that tends to the fraction
of SEATED nodes as the noise vanishes, whose standard error is the spread over seeds, and
that is reproducible from its seed."""

from __future__ import annotations

import math
import statistics

import pytest

import xface_core as xf
from xface_core.study.noise import PoseNoise, mean_seat_probability

DESIGN = xf.x_face(0.5, 1.0)
PHYSICS = xf.Physics()


def test_vanishing_noise_gives_the_fraction_of_seated_nodes() -> None:
    grid = 11
    p = mean_seat_probability(DESIGN, PoseNoise(1e-9, 1e-9, samples=4), grid=grid, physics=PHYSICS)
    m = xf.acceptance_map(DESIGN, grid=grid).M
    assert p.mean == pytest.approx(m / grid**2, abs=1e-12)
    assert p.standard_error == 0.0  # every draw of a node has the node's outcome


def test_the_standard_error_is_the_spread_of_the_estimate_over_seeds() -> None:
    runs = [
        mean_seat_probability(
            DESIGN, PoseNoise(0.1, 0.1, samples=8, seed=s), grid=5, physics=PHYSICS
        )
        for s in range(30)
    ]
    spread = statistics.stdev(r.mean for r in runs)
    reported = math.sqrt(statistics.fmean(r.standard_error**2 for r in runs))
    assert 0.6 < spread / reported < 1.6


def test_the_estimate_is_reproducible_from_its_seed() -> None:
    noise = PoseNoise(0.1, 0.1, seed=7)
    a = mean_seat_probability(DESIGN, noise, grid=7, physics=PHYSICS)
    b = mean_seat_probability(DESIGN, noise, grid=7, physics=PHYSICS)
    c = mean_seat_probability(DESIGN, PoseNoise(0.1, 0.1, seed=8), grid=7, physics=PHYSICS)
    assert a == b
    assert a != c


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"sigma_x": -0.1, "sigma_theta": 0.1}, "sigma_x"),
        ({"sigma_x": 0.1, "sigma_theta": float("nan")}, "sigma_theta"),
        ({"sigma_x": 2.0, "sigma_theta": 0.1}, "sigma_x"),
        ({"sigma_x": 0.1, "sigma_theta": 1.0}, "sigma_theta"),
        ({"sigma_x": 0.1, "sigma_theta": 0.1, "samples": 1}, "samples"),
        ({"sigma_x": 0.1, "sigma_theta": 0.1, "samples": 10**6}, "samples"),
        ({"sigma_x": 0.1, "sigma_theta": 0.1, "seed": -1}, "seed"),
    ],
)
def test_bad_noise_is_refused(kwargs: dict[str, float], message: str) -> None:
    with pytest.raises(xf.XfaceValueError, match=message):
        PoseNoise(**kwargs)  # type: ignore[arg-type]
