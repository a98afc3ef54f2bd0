#!/usr/bin/env python3
"""Issue 35 as a new user met it: ``make demo`` on a fresh clone, on a busy machine.

    python3 scripts/evidence/demo_fresh_clone.py                   # its own .venv: ~1 GB, minutes
    .venv/bin/python scripts/evidence/demo_fresh_clone.py --venv .venv   # installed venv: quicker

Clones the repository's HEAD (``git clone`` of this checkout: uncommitted files never leak
in) into a temporary folder, starts ``--busy`` (default 2) CPU-bound processes beside it
(``python -c "while True: pass"``, ended by their process ids at the end, whatever happens),
and runs ``make demo`` in the clone. Without ``--venv`` make creates the clone's own
``.venv`` and installs xface with its ROS and test extras into it, as on a fresh machine;
with ``--venv PATH`` it runs ``make demo VENV=PATH`` on that installed virtualenv instead
(the clone's code first on ``PYTHONPATH``, and its ``pyproject.toml`` dated before the venv's
install stamp, so make installs nothing into a venv that others may be using).

Checks that make exits 0, that the demo showed every kind of answer (a seat, a jam, out of
reach, a miss, an invalid input) and the planner's answer and ended with its ``OK``, and
that ``rerun rrd verify`` accepts the recording it wrote. Prints the timings (set-up: the
clone and make's install, up to the demo's first line; node ready: the demo's own count from
the node's start to its warm-up's end, with where the simulator came from; demo: from then
to make's exit) and, last, a one-line verdict; exits 0 on PASS, 1 on FAIL. make's output is
echoed (``--quiet``: not) and kept in the folder, which is removed at the end unless
``--keep``.

DDS stays on this machine: ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``, no static peers and
a ``ROS_DOMAIN_ID`` of its own (``--domain-id``, default 1-99 from the process id, as make's).
No ``NUMBA_*`` or ``XFACE_*`` variable is passed on: the clone compiles or loads its engine as
a new user's would. Standard library only (it runs before any venv exists).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import queue
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: make's install stamp in a venv (the Makefile's STAMP): present once make installed it.
INSTALL_STAMP = ".xface-installed"
#: Where the demo writes its recording, in the directory make runs it in.
RECORDING = "xface-demo.rrd"
#: Every kind of answer the demo's sweep must show: what it is called, and its line.
ANSWER_LINES = {
    "a seat": r"-> SEATED +accepted",
    "a jam": r"-> BAD_MATE +will not seat",
    "out of reach": r"-> OUT_OF_REACH +will not seat",
    "a miss": r"-> NO_CONTACT +will not seat",
    "an invalid input": r" invalid +INVALID_INPUT: ",
}
#: The demo's line with the planner's answer (a plan to the seat, or an empty plan).
PLANNER_LINE = r"xface demo: planner answer: (a plan of \d+ poses|an empty plan)"
#: How long make may take at most (s): an install of ~1 GB and a compile under load.
MAKE_TIMEOUT_S = 3600.0
#: How long make may take to end after a SIGINT (the demo stops its node first).
MAKE_STOP_S = 180.0


@dataclass
class Timings:
    """Wall-clock marks of one run (``time.monotonic``), from the script's start."""

    started: float = field(default_factory=time.monotonic)
    demo_started: float | None = None  # the demo's first line: set-up is over
    node_ready_s: float | None = None  # the demo's own count, node start to warmed up
    engine: str = "?"  # where the node's simulator came from
    ready_at: float | None = None
    make_ended: float | None = None

    def see(self, line: str) -> None:
        """Take the marks a line of make's output carries."""
        now = time.monotonic()
        if self.demo_started is None and line.startswith("xface demo: ROS_DOMAIN_ID="):
            self.demo_started = now
        ready = re.match(r"xface demo: node ready after ([\d.]+) s \(simulator: (\w+)\)", line)
        if ready is not None:
            self.node_ready_s, self.engine, self.ready_at = float(ready[1]), ready[2], now

    def summary(self) -> str:
        def since(start: float | None, end: float | None) -> str:
            return "-" if start is None or end is None else f"{end - start:.1f} s"

        ready = "-" if self.node_ready_s is None else f"{self.node_ready_s:.1f} s"
        return (
            f"set-up {since(self.started, self.demo_started)}, node ready {ready} "
            f"(simulator: {self.engine}), demo {since(self.ready_at, self.make_ended)}; "
            f"total {since(self.started, self.make_ended)}"
        )


def check_demo_output(text: str) -> list[str]:
    """What the demo's output lacks of a good run (every kind of answer, the planner's
    answer, its OK); empty when nothing."""
    problems = [
        f"no answer showing {name}"
        for name, pattern in ANSWER_LINES.items()
        if re.search(pattern, text) is None
    ]
    if re.search(PLANNER_LINE, text) is None:
        problems.append("no planner answer")
    if re.search(r"^xface demo: OK$", text, flags=re.MULTILINE) is None:
        verdict = re.search(r"^xface demo: FAILED: .*$", text, flags=re.MULTILINE)
        problems.append(verdict[0] if verdict else "the demo did not say OK")
    return problems


@contextlib.contextmanager
def busy_processes(count: int) -> Iterator[list[subprocess.Popen[bytes]]]:
    """``count`` CPU-bound processes for the duration of the block, each ended by its own
    process id afterwards, also when the block raises."""
    started: list[subprocess.Popen[bytes]] = []
    try:
        for _ in range(count):
            started.append(subprocess.Popen([sys.executable, "-c", "while True: pass"]))
        yield started
    finally:
        for process in started:
            process.kill()
            process.wait()


def make_arguments(venv: Path | None, clone: Path) -> list[str]:
    """The ``make demo`` command line; with ``venv``, also dates the clone's pyproject.toml
    before the venv's install stamp, so make installs nothing into it (ValueError for a venv
    make has not installed: make would install into it)."""
    if venv is None:
        return ["make", "demo"]
    stamp = venv / INSTALL_STAMP
    if not stamp.is_file():
        raise ValueError(
            f"{venv} has no {INSTALL_STAMP}: make has not installed it, and would install into "
            "it (run make setup there first, or leave out --venv)"
        )
    before = stamp.stat().st_mtime - 60.0
    os.utime(clone / "pyproject.toml", (before, before))
    return ["make", "demo", f"VENV={venv}"]


def child_environment(domain_id: int, clone: Path, venv: Path | None) -> dict[str, str]:
    """make's environment: DDS on loopback in ``domain_id``; no NUMBA_*/XFACE_* settings;
    with ``venv``, the clone's code first on the path (the venv may hold another checkout)."""
    env = {
        key: value
        for key, value in os.environ.items()
        if not key.startswith(("NUMBA_", "XFACE_", "ROS_")) and key != "PYTHONPATH"
    }
    env |= {
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
        "ROS_STATIC_PEERS": "",
        "ROS_DOMAIN_ID": str(domain_id),
        "PYTHONUNBUFFERED": "1",
    }
    if venv is not None:
        env["PYTHONPATH"] = str(clone)
    return env


def run_make(
    command: list[str], clone: Path, env: dict[str, str], log: Path, *, echo: bool,
    timings: Timings,
) -> tuple[int | None, str]:  # fmt: skip
    """Run make in ``clone`` (a session of its own), echo and keep its output and take the
    timings' marks; its exit code (None when it ran past :data:`MAKE_TIMEOUT_S` and was
    stopped) and its output."""
    lines: queue.Queue[str | None] = queue.Queue()
    make = subprocess.Popen(
        command, cwd=clone, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
        text=True, errors="replace", start_new_session=True,
    )  # fmt: skip

    def read() -> None:
        assert make.stdout is not None
        for line in make.stdout:
            lines.put(line)
        lines.put(None)

    threading.Thread(target=read, daemon=True).start()
    deadline = time.monotonic() + MAKE_TIMEOUT_S
    out: list[str] = []
    code: int | None = None
    try:
        with log.open("w", encoding="utf-8") as kept:
            while (line := lines.get(timeout=max(deadline - time.monotonic(), 0.0))) is not None:
                timings.see(line)
                out.append(line)
                kept.write(line)
                if echo:
                    print(f"  | {line}", end="", flush=True)
        code = make.wait()
    except queue.Empty:
        print(f"demo_fresh_clone: make ran past {MAKE_TIMEOUT_S:g} s: stopping it", flush=True)
    finally:
        timings.make_ended = time.monotonic()
        _stop_session(make)
    return code, "".join(out)


def _stop_session(make: subprocess.Popen[str]) -> None:
    """End make's session if it still runs: SIGINT (the demo stops its node and finishes its
    recording), SIGKILL after :data:`MAKE_STOP_S`."""
    if make.poll() is not None:
        return
    os.killpg(make.pid, signal.SIGINT)
    try:
        make.wait(timeout=MAKE_STOP_S)
    except subprocess.TimeoutExpired:
        os.killpg(make.pid, signal.SIGKILL)
        make.wait()


def verify_recording(rerun: Path, recording: Path) -> str | None:
    """``rerun rrd verify``: None when it accepts the recording, else why not."""
    if not recording.is_file():
        return f"no recording at {recording}"
    if not rerun.exists():
        return f"no {rerun} to verify the recording with"
    run = subprocess.run(
        [str(rerun), "rrd", "verify", str(recording)],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    if run.returncode == 0:
        return None
    said = (run.stderr + run.stdout).strip().splitlines()
    return f"rerun rrd verify failed: {said[0] if said else run.returncode}"


def _parse(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="demo_fresh_clone.py", description=__doc__.split("\n")[0])
    venv_help = "an installed virtualenv for make demo VENV=... (default: the clone's own .venv)"
    parser.add_argument("--venv", type=Path, help=venv_help)
    parser.add_argument("--busy", type=int, default=2, help="CPU-bound processes (default 2)")
    domain_help = "ROS_DOMAIN_ID of the demo (default 1-99 from the process id)"
    parser.add_argument("--domain-id", type=int, default=os.getpid() % 99 + 1, help=domain_help)
    parser.add_argument("--keep", action="store_true", help="keep the temporary folder")
    parser.add_argument("--quiet", action="store_true", help="do not echo make's output")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = _parse(argv)
    venv = args.venv.resolve() if args.venv is not None else None
    timings = Timings()
    folder = Path(tempfile.mkdtemp(prefix="xface-fresh-clone-"))
    clone = folder / "xface"
    problems: list[str] = []
    try:
        subprocess.run(["git", "clone", "--quiet", str(ROOT), str(clone)], check=True)
        head = subprocess.run(
            ["git", "-C", str(clone), "rev-parse", "--short", "HEAD"],
            capture_output=True, text=True, check=True,
        ).stdout.strip()  # fmt: skip
        command = make_arguments(venv, clone)
        env = child_environment(args.domain_id, clone, venv)
        print(
            f"demo_fresh_clone: {head} cloned into {clone}; {' '.join(command)} beside "
            f"{args.busy} busy processes, ROS_DOMAIN_ID={args.domain_id} on localhost",
            flush=True,
        )
        with busy_processes(args.busy):
            code, out = run_make(
                command, clone, env, folder / "make.log", echo=not args.quiet, timings=timings
            )
        if code != 0:
            problems.append(f"make demo exit code {code}")
        problems += check_demo_output(out)
        rerun = (venv or clone / ".venv") / "bin" / "rerun"
        unverified = verify_recording(rerun, clone / RECORDING)
        if unverified is not None:
            problems.append(unverified)
    except (ValueError, subprocess.CalledProcessError, OSError) as exc:
        problems.append(str(exc))
    except KeyboardInterrupt:
        problems.append("interrupted")
    finally:
        if args.keep:
            print(f"demo_fresh_clone: kept {folder} (make.log, the clone, its recording)")
        else:
            shutil.rmtree(folder, ignore_errors=True)
    print(f"demo_fresh_clone: timings: {timings.summary()}", flush=True)
    if problems:
        print(f"demo_fresh_clone: FAIL: {'; '.join(problems)}", flush=True)
        return 1
    print(
        "demo_fresh_clone: PASS: make demo exited 0 with every kind of answer and the "
        "planner's answer, and its recording verifies",
        flush=True,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
