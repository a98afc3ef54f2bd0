"""Every reproducer of issue 37's range probe (``../shared/repro/engine_range.py``) as a test.

Outside the verified range (H/D or r_p above :data:`~xface_core.geometry.MAX_DESIGN_RATIO`) the
design is now refused with an error that states the limit; inside it each run must pass the
issue's bar (no interpenetration beyond 1e-6 D along the path, no UNRESOLVED, a mirror-symmetric
design's mirror pair equal, a map filled by symmetry equal to its simulation), checked by the
probe's own code (scripts/evidence/range_probe.py). Reproducers inside the range that still fail
are engine defects, marked ``xfail(strict=True)``: fixing the engine turns them into failures
that say to drop the mark. The seeded probe itself runs small here, within the accepted range.
"""

from __future__ import annotations

import importlib
import json
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from xface_core import Outcome
from xface_core.cli import main
from xface_core.errors import XfaceValueError
from xface_core.geometry import MAX_DESIGN_RATIO

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scripts" / "evidence"))
range_probe = importlib.import_module("range_probe")
Run: Any = range_probe.Run

ENGINE_DEFECT = "engine defect inside the verified range (issue 37): "
NEEDLES_0 = ENGINE_DEFECT + (
    "custom face (H/D about 3, damping ratio 1e4): two needle tips (0.99 and 1.23 degrees) in "
    "contact while their flanks cross the base's outline 2.2e-4 D deep"
)
NEEDLE_1 = ENGINE_DEFECT + (
    "custom face (H/D about 3, default physics): a 0.79-degree needle tip of the base in "
    "contact while its flanks cross the moving outline 3.9e-4 D deep"
)
FRICTION_MIRROR_7 = ENGINE_DEFECT + (
    "mirror-symmetric custom face with friction: the jam at (-x0, -theta0) stops at angles "
    "0.03-0.09 rad from the mirror image of the jam at (x0, theta0) (exact with friction 0)"
)
LIGHT_BASE_9 = ENGINE_DEFECT + (
    "V 0.98/0 at damping ratio 1e-4 (UNRESOLVED up to 1e-3, seated from 1e-2) with friction "
    "0.3-0.46: the event limit is reached"
)

#: Built-in designs beyond H/D 50: refused now (they interpenetrated up to 0.47 D, ended
#: UNRESOLVED, or disagreed with their mirror or with symmetry filling).
REFUSED = [
    pytest.param(
        # overlap: interpenetration 4.66e-01 D (area 4.06e-04) at sample 106/108
        Run(
            2,
            "X",
            342.1492809878376,
            0.002880499463475846,
            4.855976268830413,
            0.6323503983055565,
            -0.7142667351791447,
            math.inf,
            0.0,
            False,
        ),
        id="2-overlap-X",
    ),
    pytest.param(
        # overlap: interpenetration 7.20e-03 D (area 4.14e-06) at sample 7194/7195
        Run(
            3,
            "V",
            464.07249613024504,
            0.00657019425869182,
            0.017762297103638074,
            -0.8129128951573945,
            0.0004300336623055401,
            0.0001,
            0.0,
            False,
        ),
        id="3-overlap-V",
    ),
    pytest.param(
        # overlap: interpenetration 1.05e-01 D (area 1.52e-04) at sample 204/4116
        Run(
            4,
            "S",
            400.1826867512177,
            0.0,
            21.284719760084652,
            62.768306323312395,
            -0.30700612412715356,
            1.5342345171403664,
            0.0,
            False,
        ),
        id="4-overlap-S",
    ),
    pytest.param(
        # mirror_outcome: mirror (-x0,-th) gives UNRESOLVED, not BAD_MATE
        Run(
            5,
            "V",
            115.30485960640566,
            0.0,
            43.9077751549351,
            -0.16810477068671137,
            -1.5445350720686208,
            1.0,
            0.0,
            False,
        ),
        id="5-mirror_outcome-V",
    ),
    pytest.param(
        # mirror_outcome: mirror (-x0,-th) gives UNRESOLVED, not BAD_MATE
        Run(
            6,
            "X",
            103.32781275978105,
            0.0,
            11.820056700343851,
            -0.2333230257056886,
            -1.142148527075291,
            6.71751972470898,
            0.0,
            False,
        ),
        id="6-mirror_outcome-X",
    ),
    pytest.param(
        # mirror_angles: mirror angles (0,2.5416094) vs (0,-1.9399454)
        Run(
            8,
            "X",
            8566.603703302388,
            0.01670921625216771,
            732.7660330892894,
            -0.6804489032807867,
            0.9046790421238726,
            math.inf,
            0.0,
            False,
        ),
        id="8-mirror_angles-X",
    ),
    pytest.param(
        # map: map grid=7 symmetric cell (4,6) x0=np.float64(3.4871989750757526e-05) th=np.float64
        Run(
            10,
            "V",
            102.03843108496764,
            0.0,
            0.00010461596925227259,
            0.1762261235402076,
            0.9835386477476629,
            0.0001,
            0.0,
            True,
        ),
        id="10-map-V",
    ),
]

#: Designs inside the verified range: each must pass the bar (or is a known engine defect).
INSIDE = [
    pytest.param(
        # overlap: interpenetration 3.58e-04 D (area 2.11e-06) at sample 65/78
        Run(
            0,
            "custom",
            math.nan,
            math.nan,
            0.8600235108585322,
            -2.502567769724775,
            0.8011143455450451,
            10000.0,
            0.0,
            False,
            base=[
                [0.5, -1.0],
                [0.5, 0.7896332573915411],
                [0.4167337321222322, 0.8023043974911415],
                [0.38376555003532653, 0.7016891490106786],
                [0.36583729603842075, 1.6850714915114766],
                [0.3100623133211754, 1.6033069876933923],
                [0.23414555080708244, 0.9299382803142826],
                [0.21753132736460068, 1.3642654680413187],
                [0.08569453799910298, 1.793305240570497],
                [0.04073921804000091, 1.9366570920569215],
                [-0.05062910036558588, 2.6682263797675976],
                [-0.10378199061352378, 3.197170518934319],
                [-0.130835203070927, 0.3837090052523915],
                [-0.15143046620824374, 3.0915532647944945],
                [-0.20079028896700657, 2.5433906054859667],
                [-0.21077542774560654, 1.3253253689957156],
                [-0.24696081707194018, 1.7545476085836795],
                [-0.3673057710783343, 3.123097219944958],
                [-0.4088438029104179, 1.3852444034395877],
                [-0.47423017709917625, 1.0544268084647628],
                [-0.4765412548514474, 2.840432653178521],
                [-0.48096075966098295, 0.43371102618620705],
                [-0.5, 1.3997313529123638],
                [-0.5, -1.0],
            ],
            moving=[
                [0.5, -1.0],
                [0.5, 2.2695181823316344],
                [0.48096075966098295, 3.235538509057791],
                [0.4765412548514474, 0.8288168820654773],
                [0.47423017709917625, 2.614822726779235],
                [0.4088438029104179, 2.2840051318044106],
                [0.3673057710783343, 0.5461523152990404],
                [0.24696081707194018, 1.9147019266603187],
                [0.21077542774560654, 2.3439241662482826],
                [0.20079028896700657, 1.1258589297580315],
                [0.15143046620824374, 0.5776962704495037],
                [0.130835203070927, 3.2855405299916067],
                [0.10378199061352378, 0.4720790163096793],
                [0.05062910036558588, 1.0010231554764006],
                [-0.04073921804000091, 1.7325924431870767],
                [-0.08569453799910298, 1.8759442946735012],
                [-0.21753132736460068, 2.3049840672026796],
                [-0.23414555080708244, 2.7393112549297154],
                [-0.3100623133211754, 2.065942547550606],
                [-0.36583729603842075, 1.9841780437325216],
                [-0.38376555003532653, 2.9675603862333197],
                [-0.4167337321222322, 2.8669451377528565],
                [-0.5, 2.879616277852457],
                [-0.5, -1.0],
            ],
            mated_distance=3.669249535243998,
            mirror_symmetric=False,
        ),
        id="0-overlap-custom",
        marks=pytest.mark.xfail(
            strict=True,
            reason=NEEDLES_0,
        ),
    ),
    pytest.param(
        # overlap: interpenetration 3.76e-04 D (area 2.10e-05) at sample 20/53
        Run(
            1,
            "custom",
            math.nan,
            math.nan,
            430.9324300487207,
            -0.5411108064063629,
            0.6607464538933172,
            1.0,
            0.0,
            False,
            base=[
                [0.5, -1.0],
                [0.5, 0.9478029288634048],
                [0.4647921487514395, 2.099110892999479],
                [0.45500861054198183, 2.955898908147141],
                [0.3370381805370879, 0.8992562767981294],
                [0.2502048060317751, 2.5760133249919126],
                [0.12781622838420736, 2.4029177319690955],
                [0.08414993148474759, 0.9439996099678176],
                [0.0574964381320463, 1.366964928637509],
                [-0.04654893548982042, 1.3833868712066275],
                [-0.056522412643186026, 3.071139600960335],
                [-0.05909064770334427, 2.744403598862193],
                [-0.0781318647344107, 0.8964303935456543],
                [-0.1415153751922107, 1.1751455315068515],
                [-0.16222211284192567, 2.1916230706530766],
                [-0.18132830398691235, 3.0775173519392576],
                [-0.4417372887317438, 2.439156396123716],
                [-0.4603385128266494, 2.8186785815343556],
                [-0.5, 2.660956057642214],
                [-0.5, -1.0],
            ],
            moving=[
                [0.5, -1.0],
                [0.5, 1.1942511399750666],
                [0.4603385128266494, 1.0365286160829252],
                [0.4417372887317438, 1.4160508014935647],
                [0.18132830398691235, 0.7776898456780232],
                [0.16222211284192567, 1.6635841269642042],
                [0.1415153751922107, 2.6800616661104293],
                [0.0781318647344107, 2.9587768040716265],
                [0.05909064770334427, 1.110803598755088],
                [0.056522412643186026, 0.7840675966569459],
                [0.04654893548982042, 2.4718203264106533],
                [-0.0574964381320463, 2.488242268979772],
                [-0.08414993148474759, 2.9112075876494634],
                [-0.12781622838420736, 1.4522894656481853],
                [-0.2502048060317751, 1.2791938726253682],
                [-0.3370381805370879, 2.9559509208191512],
                [-0.45500861054198183, 0.8993082894701399],
                [-0.4647921487514395, 1.756096304617802],
                [-0.5, 2.907404268753876],
                [-0.5, -1.0],
            ],
            mated_distance=3.855207197617281,
            mirror_symmetric=False,
        ),
        id="1-overlap-custom",
        marks=pytest.mark.xfail(
            strict=True,
            reason=NEEDLE_1,
        ),
    ),
    pytest.param(
        # mirror_angles: mirror angles (-0.018631303,1.552165) vs (0.046346725,-1.6386849)
        Run(
            7,
            "custom",
            math.nan,
            math.nan,
            9.510291729287944,
            -0.1298420932506208,
            1.4984894359002068,
            0.0001,
            6.4065564822599725,
            False,
            base=[
                [0.5, -1.0],
                [0.5, 0.7223996806985016],
                [0.4989359957501004, 1.3019488194309399],
                [0.4877714559747419, 1.4169060872136234],
                [0.47140118520443397, 1.5269565409188899],
                [0.3792595280164687, 0.8134078312940601],
                [0.3749533895507117, 1.2603825846178487],
                [0.22905899782039413, 1.1630054735700082],
                [0.11699880356783093, 0.20499440697556442],
                [0.07165722468316088, 1.4226281627196409],
                [0.0544027772962562, 0.7094978480188393],
                [0.0, 0.4377154006074023],
                [-0.0544027772962562, 0.7094978480188393],
                [-0.07165722468316088, 1.4226281627196409],
                [-0.11699880356783093, 0.20499440697556442],
                [-0.22905899782039413, 1.1630054735700082],
                [-0.3749533895507117, 1.2603825846178487],
                [-0.3792595280164687, 0.8134078312940601],
                [-0.47140118520443397, 1.5269565409188899],
                [-0.4877714559747419, 1.4169060872136234],
                [-0.4989359957501004, 1.3019488194309399],
                [-0.5, 0.7223996806985016],
                [-0.5, -1.0],
            ],
            moving=[
                [0.5, -1.0],
                [0.5, 0.9994831444467236],
                [0.4989359957501004, 0.4199340057142853],
                [0.4877714559747419, 0.30497673793160174],
                [0.47140118520443397, 0.1949262842263353],
                [0.3792595280164687, 0.908474993851165],
                [0.3749533895507117, 0.4615002405273765],
                [0.22905899782039413, 0.558877351575217],
                [0.11699880356783093, 1.5168884181696607],
                [0.07165722468316088, 0.2992546624255843],
                [0.0544027772962562, 1.012384977126386],
                [-0.0, 1.2841674245378227],
                [-0.0544027772962562, 1.012384977126386],
                [-0.07165722468316088, 0.2992546624255843],
                [-0.11699880356783093, 1.5168884181696607],
                [-0.22905899782039413, 0.558877351575217],
                [-0.3749533895507117, 0.4615002405273765],
                [-0.3792595280164687, 0.908474993851165],
                [-0.47140118520443397, 0.1949262842263353],
                [-0.4877714559747419, 0.30497673793160174],
                [-0.4989359957501004, 0.4199340057142853],
                [-0.5, 0.9994831444467236],
                [-0.5, -1.0],
            ],
            mated_distance=1.7218828251452252,
            mirror_symmetric=True,
        ),
        id="7-mirror_angles-custom",
        marks=pytest.mark.xfail(
            strict=True,
            reason=FRICTION_MIRROR_7,
        ),
    ),
    pytest.param(
        # unresolved: UNRESOLVED (event limit reached before an outcome was decided)
        Run(
            9,
            "V",
            0.9822283062413161,
            0.0,
            12.800598349870178,
            -0.4943404346891451,
            0.7059746373216553,
            0.0001,
            0.4589249111199053,
            False,
        ),
        id="9-unresolved-V",
        marks=pytest.mark.xfail(
            strict=True,
            reason=LIGHT_BASE_9,
        ),
    ),
]


@pytest.mark.parametrize("run", REFUSED)
def test_a_reproducer_beyond_the_verified_range_is_refused_with_its_limit(run: Any) -> None:
    with pytest.raises(XfaceValueError, match=r"h_over_d must be <= 50 \(the range the engine"):
        run.design()


@pytest.mark.parametrize("run", INSIDE)
def test_a_reproducer_inside_the_verified_range_passes_the_bar(run: Any) -> None:
    assert range_probe.check_run(run) == []


def test_the_seeded_probe_over_the_accepted_range_is_clean(tmp_path: Path) -> None:
    """200 seeded runs over everything FaceDesign and Physics accept (the CI-sized probe)."""
    out = tmp_path / "findings.json"
    args = ["--runs", "200", "--seed", "37", "--timeout", "120", "--json", str(out)]
    assert range_probe.main(args) == 0
    assert json.loads(out.read_text()) == []


def test_the_probe_exits_1_and_writes_each_finding_with_its_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The probe can fail: one run with a finding makes it exit 1 and write that run."""

    def one_finding(run: Any) -> list[tuple[str, str]]:
        return [("overlap", "planted")] if run.index == 1 else []

    monkeypatch.setattr(range_probe, "check_run", one_finding)  # forked workers inherit it
    out = tmp_path / "findings.json"
    assert range_probe.main(["--runs", "3", "--seed", "0", "--json", str(out)]) == 1
    (row,) = json.loads(out.read_text())
    assert row["run"]["index"] == 1
    assert row["findings"] == [["overlap", "planted"]]


def test_the_overlap_depth_is_the_deepest_vertex_or_the_crossing_thickness() -> None:
    square = np.array([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)])
    pushed_in = square / 2 + np.array([0.25, 0.9])  # two vertices 0.1 inside the square
    assert range_probe.overlap_depth(square, pushed_in) == pytest.approx(0.1)
    touching = square / 2 + np.array([0.25, 1.0])
    assert range_probe.overlap_depth(square, touching) == 0.0
    # A plus sign: no vertex of either bar inside the other, a 0.2 x 0.2 overlap.
    bar = np.array([(-1.0, -0.1), (1.0, -0.1), (1.0, 0.1), (-1.0, 0.1)])
    assert range_probe.overlap_depth(bar, bar[:, ::-1]) == pytest.approx(0.1, rel=0.02)


def test_predict_answers_at_the_largest_accepted_design(capsys: pytest.CaptureFixture[str]) -> None:
    limit = f"{MAX_DESIGN_RATIO:g}"
    argv = ["predict", "--face", "X", "--h-over-d", limit, "--rp", limit]
    assert main([*argv, "--x0", "0.5", "--theta0", "0.3", "--json"]) == 0
    outcome = json.loads(capsys.readouterr().out)["outcome"]
    assert outcome in {o.name for o in Outcome} - {"UNRESOLVED"}


def test_predict_beyond_the_largest_accepted_design_is_refused_with_its_limit(
    capsys: pytest.CaptureFixture[str],
) -> None:
    argv = ["predict", "--face", "X", "--h-over-d", "10000", "--rp", "10000"]
    assert main([*argv, "--x0", "0.5", "--theta0", "0.3"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    expected = (
        "xface: error: h_over_d must be <= 50 (the range the engine is verified over; "
        "docs/model.md, Range), got 10000.0"
    )
    assert err == [expected]
