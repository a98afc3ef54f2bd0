"""scripts/evidence/release_dips.py: a held contact never lets go inside an accepted step.

The audit solves the quasi-static Coulomb problem by enumeration at states inside xface's
steps; audited with other dampers than the path was solved with, it must find the held
contacts unable to stay closed, so the clean run below is not a test that cannot fail.
"""

from __future__ import annotations

import importlib
import math
import sys
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts" / "evidence"))
dips: Any = importlib.import_module("release_dips")


def _motion(mode: str, gap_rate: float) -> Any:
    return dips.Motion(
        modes=(mode,),
        w_b=0.0,
        w_m=1.0,
        lam=(0.0,),
        friction=(0.0,),
        gap_rate=(gap_rate,),
        slip_rate=(0.0,),
        drive=-1.0,
        family_dim=0,
    )


def test_a_separating_contact_does_not_keep_the_contacts() -> None:
    assert not dips.keeps_contacts([_motion("sep", 0.5)])
    assert not dips.keeps_contacts([])


@pytest.mark.parametrize(("mode", "rate"), [("slide+", 0.0), ("stick", 0.0), ("sep", 1e-12)])
def test_a_motion_with_every_contact_closed_keeps_them(mode: str, rate: float) -> None:
    assert dips.keeps_contacts([_motion("sep", 0.5), _motion(mode, rate)])


def test_xface_paths_have_no_release_dip(capsys: pytest.CaptureFixture[str]) -> None:
    assert dips.main(["--cells", "2", "--seed", "11"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("32 cells, ")
    assert int(out.split(", ")[1].split()[0]) > 500  # states checked: the audit saw steps
    assert ", 0 dips" in out


def test_the_audit_finds_dips_on_a_path_solved_with_other_dampers(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from xface_core import x_face

    solved = dips.predict
    # The path with equal dampers, audited as if the base were held.
    monkeypatch.setattr(
        dips, "predict", lambda d, x0, t0, friction, damping_ratio: solved(d, x0, t0)
    )
    x0, theta0 = -0.6167674819597295, 0.7256739867228721
    checked, found = dips.audit(x_face(1.0, 1.0), x0, theta0, 0.0, math.inf)
    assert checked > 100
    assert len(found) > 10
    monkeypatch.undo()
    checked, found = dips.audit(x_face(1.0, 1.0), x0, theta0, 0.0, 1.0)
    assert checked > 100
    assert found == []


def test_nonsense_arguments_are_refused(capsys: pytest.CaptureFixture[str]) -> None:
    assert dips.main(["--cells", "0"]) == 2
    assert "release_dips: error: --cells and --inner must be >= 1" in capsys.readouterr().err
