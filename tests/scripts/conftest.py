"""Fixtures shared by the tests of the scripts under scripts/."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import pytest


@pytest.fixture
def usage_error(capsys: pytest.CaptureFixture[str]) -> Callable[..., str]:
    """Run a script's ``main(argv)`` that must end in argparse's usage error: exit code 2, no
    traceback; returns the error's last line."""

    def run(main: Callable[[Sequence[str]], int], argv: Sequence[str]) -> str:
        with pytest.raises(SystemExit) as ended:
            main(argv)
        assert ended.value.code == 2
        err = capsys.readouterr().err
        assert "Traceback" not in err
        last = err.splitlines()[-1]
        assert ": error: " in last
        return last

    return run
