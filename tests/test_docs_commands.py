"""Every command block of README.md and docs/*.md runs as written (issue 14).

A fenced block tagged ``sh`` or ``bash`` is a command block: what a user pastes into a shell
after the documented set-up (the virtualenv of ``make setup``, activated). A block tagged
``python`` is what a user pastes into Python in that virtualenv; the Python blocks of one file
build on each other (the second uses the first's names), so each runs after its file's earlier
Python blocks, as one script. Each one runs on its
own, in a fresh scratch copy of the repository, and must exit 0. The convention for what the
blocks cannot say themselves (docs/development.md) is an HTML comment on the lines right
before the block's opening fence:

* ``<!-- docs-test: skip: REASON -->``: not run (a reason is required and the skips are
  listed by :func:`test_skipped_blocks_say_why`);
* ``<!-- docs-test: background -->`` or ``<!-- docs-test: background: TEXT -->``: the block is
  one long-running command (the node): it must still run after ``BACKGROUND_S`` seconds, or
  once its output shows TEXT, and then exit 0 on Ctrl-C (SIGINT);
* ``<!-- docs-test: slow -->``: the block takes long; its test is marked ``slow``;
* ``<!-- docs-test: excerpt: PATH -->`` (Python blocks): the block quotes the source file PATH
  (lines of it, dedented) rather than being a script: it must still be there, word for word.

Every other fence needs a tag (``text`` for syntax, output and drawings), so no command hides
in an untagged block. Commands run with ``bash -e -o pipefail`` in a scratch directory that
holds the repository's files (not the packages: those are imported from this checkout, where
the compiled simulator is cached), a ``.venv`` that is the virtualenv running this test, and
that virtualenv's ``bin`` first on PATH, as ``source .venv/bin/activate`` leaves it. Every block
gets the suite's ROS isolation (discovery on this host, no static peers) and a ROS domain of
its own; a block that starts ROS is marked ``ros``. A block's processes are one process group,
stopped after it (background ``&`` jobs included).
"""

from __future__ import annotations

import contextlib
import importlib.util
import os
import re
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
SHELL_TAGS = {"sh", "bash"}

#: Runs the command after it with SIGINT at its default disposition, as in a terminal: a suite
#: started from a background job of a shell without job control inherits SIGINT ignored, and
#: a non-interactive bash can neither trap nor reset a signal ignored on entry (``trap - INT``
#: leaves it ignored), so a block would never see the Ctrl-C of a background block's test.
_RESET_SIGINT = "import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_DFL); "
DEFAULT_SIGINT = [sys.executable, "-c", _RESET_SIGINT + "os.execvp(sys.argv[1], sys.argv[1:])"]
#: What a fence may be tagged with; a new tag is a decision (is it a command?), not an accident.
KNOWN_TAGS = SHELL_TAGS | {"python", "yaml", "text", "json", "toml", "xml"}
#: A block's run, at most (the slowest, a Dask sweep or a full-size table, take about a minute).
TIMEOUT_S = 240.0
#: How long a background block must keep running when it names no text to wait for.
BACKGROUND_S = 8.0
#: How long a background block may take to show its text, and to stop after Ctrl-C.
BACKGROUND_READY_S = 180.0
BACKGROUND_STOP_S = 60.0
#: Commands that start rclpy (the node, its pose source, the demo, the stress script).
ROS_COMMAND = re.compile(r"xface-predictor|xface_ros|make demo|ros_stress|\bros2\b")
#: The packages: imported from this checkout, not copied (numba caches beside the sources).
NOT_COPIED = {"xface_core", "xface_ros", ".venv", ".git"}
#: A front page, not a manual: the rest is in docs/ (251 lines plus the changes section).
README_MAX_LINES = 275

_FENCE = re.compile(r"^(\s*)```(\S*)\s*$")
_DIRECTIVE = re.compile(r"^\s*<!--\s*docs-test:\s*(.*?)\s*-->\s*$")


@dataclass(frozen=True)
class Block:
    """One fenced block: where it is, its tag, its text (dedented) and its directives."""

    path: Path
    line: int  # of the opening fence, 1-based
    tag: str
    text: str
    directives: tuple[str, ...]

    @property
    def name(self) -> str:
        return f"{self.path.relative_to(ROOT)}:{self.line}"

    def directive(self, kind: str) -> str | None:
        """The argument of directive ``kind`` ("" when it has none), None when absent."""
        for d in self.directives:
            head, _, arg = d.partition(":")
            if head.strip() == kind:
                return arg.strip()
        return None


def fenced_blocks(path: Path) -> list[Block]:
    """Every fenced block of a Markdown file, with the ``docs-test`` comments before it."""
    lines = path.read_text(encoding="utf-8").splitlines()
    blocks, i = [], 0
    while i < len(lines):
        m = _FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        indent, tag = m.group(1), m.group(2)
        end = i + 1
        while end < len(lines) and lines[end].strip() != "```":
            end += 1
        assert end < len(lines), f"{path.name}:{i + 1}: unclosed fence"
        directives, k = [], i - 1
        while k >= 0 and (d := _DIRECTIVE.match(lines[k])):
            directives.insert(0, d.group(1))
            k -= 1
        body = [line.removeprefix(indent) for line in lines[i + 1 : end]]
        blocks.append(Block(path, i + 1, tag, "\n".join(body) + "\n", tuple(directives)))
        i = end + 1
    return blocks


ALL_BLOCKS = [b for path in DOCS for b in fenced_blocks(path)]
COMMAND_BLOCKS = [b for b in ALL_BLOCKS if b.tag in SHELL_TAGS]
RUN_BLOCKS = [b for b in COMMAND_BLOCKS if b.directive("skip") is None]
PYTHON_BLOCKS = [b for b in ALL_BLOCKS if b.tag == "python"]
EXCERPTS = [b for b in PYTHON_BLOCKS if b.directive("excerpt") is not None]
RUN_PYTHON = [b for b in PYTHON_BLOCKS if b.directive("skip") is None and b not in EXCERPTS]


def as_script(block: Block) -> str:
    """``block`` after the earlier Python blocks of its file that run: one script."""
    earlier = [b for b in RUN_PYTHON if b.path == block.path and b.line <= block.line]
    return "".join(b.text for b in earlier)


def _params(blocks: list[Block]) -> list[object]:
    params = []
    for b in blocks:
        marks = []
        if ROS_COMMAND.search(b.text):
            marks.append(pytest.mark.ros)
        if b.directive("slow") is not None:
            marks.append(pytest.mark.slow)
        params.append(pytest.param(b, id=b.name, marks=marks))
    return params


# --- the blocks themselves -------------------------------------------------------------------


def test_the_extraction_finds_the_documents_command_blocks() -> None:
    # Guards the tests below against an extraction that finds nothing (and so runs nothing).
    assert len(DOCS) > 10
    assert len(RUN_BLOCKS) >= 10
    names = {b.path.name for b in RUN_BLOCKS}
    assert {"README.md", "ros.md", "study.md", "recording.md"} <= names


def test_fenced_block_parser_reads_tags_directives_and_indentation(tmp_path: Path) -> None:
    doc = tmp_path / "doc.md"
    doc.write_text(
        "text\n\n<!-- docs-test: slow -->\n<!-- docs-test: background: ready -->\n"
        "```sh\nxface map\n```\n\n1. step\n\n   ```bash\n   echo a\n     echo b\n   ```\n"
        "```\nart\n```\n",
        encoding="utf-8",
    )
    first, second, third = fenced_blocks(doc)
    assert (first.line, first.tag, first.text) == (5, "sh", "xface map\n")
    assert first.directive("slow") == ""
    assert first.directive("background") == "ready"
    assert first.directive("skip") is None
    assert (second.tag, second.text, second.directives) == ("bash", "echo a\n  echo b\n", ())
    assert third.tag == ""


def test_every_fence_is_tagged() -> None:
    # An untagged block could hide a command from this test; drawings and output are `text`.
    bad = [f"{b.name} ({b.tag or 'untagged'})" for b in ALL_BLOCKS if b.tag not in KNOWN_TAGS]
    assert bad == []


def test_directives_are_known_and_only_on_blocks_that_run() -> None:
    bad = []
    for b in ALL_BLOCKS:
        for d in b.directives:
            kind = d.partition(":")[0].strip()
            python_kinds = {"skip", "slow", "excerpt"}
            allowed = {"skip", "background", "slow"} if b.tag in SHELL_TAGS else python_kinds
            if kind not in allowed or b.tag not in SHELL_TAGS | {"python"}:
                bad.append(f"{b.name}: {d!r}")
    assert bad == []
    # And none astray (a blank line between it and its fence would detach it unnoticed).
    lines = [line for path in DOCS for line in path.read_text(encoding="utf-8").splitlines()]
    assert sum(bool(_DIRECTIVE.match(line)) for line in lines) == sum(
        len(b.directives) for b in ALL_BLOCKS
    )


def test_skipped_blocks_say_why() -> None:
    skipped = {
        b.name: b.directive("skip")
        for b in COMMAND_BLOCKS + PYTHON_BLOCKS
        if b.directive("skip") is not None
    }
    print("\nskipped command blocks:")
    for name, reason in skipped.items():
        print(f"  {name}: {reason}")
    # A reason in words, not a bare marker; and fewer skipped than run.
    assert all(len(reason or "") >= 15 for reason in skipped.values()), skipped
    assert len(skipped) < len(RUN_BLOCKS), skipped


def test_readme_is_short_and_stays_in_the_repository() -> None:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= README_MAX_LINES
    targets = re.findall(r"\]\(([^)\s]+)\)", text)
    assert targets, "the README links its docs"
    outside = [t for t in targets if re.match(r"[a-z][a-z0-9+.-]*:", t) or t.startswith("..")]
    assert outside == []
    missing = [t for t in targets if not (ROOT / t.partition("#")[0]).exists()]
    assert missing == []
    assert re.findall(r"https?://\S+", text) == []  # no bare or reference-style web link either


# --- running them ----------------------------------------------------------------------------


def _venv() -> Path:
    if sys.prefix == sys.base_prefix:
        pytest.skip("the documented set-up is a virtualenv (make setup); this Python is none")
    return Path(sys.prefix)


def scratch_copy(dest: Path) -> Path:
    """The repository's files in ``dest`` (not the packages), with ``.venv`` the virtualenv
    running this test: its entries linked, its install stamp new so ``make`` installs nothing
    (the set-up is done: this test runs in it)."""
    try:
        listed = subprocess.run(
            ["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True, timeout=60
        ).stdout.decode()
        files = [Path(f) for f in listed.split("\0") if f]
    except (OSError, subprocess.CalledProcessError):
        files = [p.relative_to(ROOT) for p in ROOT.rglob("*") if p.is_file()]
    for rel in files:
        if rel.parts[0] in NOT_COPIED or not (ROOT / rel).is_file():
            continue
        (dest / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / rel, dest / rel)
    venv = dest / ".venv"
    venv.mkdir()
    # The set-up's stamps, made here rather than linked: make sees this virtualenv set up (the
    # install and the interfaces built) and neither installs nor builds into the shared one.
    stamps = (".xface-installed", ".xface-msgs")
    for entry in _venv().iterdir():
        if entry.name not in stamps:
            (venv / entry.name).symlink_to(entry)
    for stamp in stamps:
        (venv / stamp).touch()
    return dest


def _environment(scratch: Path, domain_id: int) -> dict[str, str]:
    env = dict(os.environ)
    tmp = scratch.parent / "tmp"  # what the commands put in temp files (Dask's workers) too
    tmp.mkdir(exist_ok=True)
    env["TMPDIR"] = str(tmp)
    bin_dir = scratch / ".venv" / "bin"
    env["PATH"] = f"{bin_dir}{os.pathsep}{env.get('PATH', '')}"
    env["VIRTUAL_ENV"] = str(scratch / ".venv")
    # This checkout's packages, whatever the virtualenv's editable install points at.
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    env["PYTHONUNBUFFERED"] = "1"
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env["ROS_STATIC_PEERS"] = ""
    env["ROS_DOMAIN_ID"] = str(domain_id)
    env.pop("PYTEST_ADDOPTS", None)  # a block that runs pytest runs it as a user would
    env.pop("MAKEFLAGS", None)  # nor `make` under `make test` (MAKEFLAGS: -k, jobs)
    env.pop("MAKELEVEL", None)
    return env


def _group_running(pgid: int) -> bool:
    """Whether a process of group ``pgid`` still runs (zombies, waiting for whoever adopted
    them to reap them, do not count)."""
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rpartition(")")[2].split()
        except OSError:
            continue  # ended meanwhile
        if int(fields[2]) == pgid and fields[0] not in "ZX":
            return True
    return False


def _stop_group(proc: subprocess.Popen[bytes]) -> None:
    """End whatever the block left running (its ``&`` jobs), TERM first, then KILL."""
    for sig, grace in ((signal.SIGTERM, 10.0), (signal.SIGKILL, 5.0)):
        if not _group_running(proc.pid):
            return
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, sig)
        deadline = time.monotonic() + grace
        while _group_running(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.2)


class BlockFailed(AssertionError):
    """A command block did not do what it says."""


def _output(log: Path) -> str:
    return log.read_text(encoding="utf-8", errors="replace")


def _tail(log: Path) -> str:
    return _output(log)[-6000:]


def _stop_on_ctrl_c(block: Block, proc: subprocess.Popen[bytes], log: Path) -> None:
    """A background block: running after ``BACKGROUND_S`` (or once its text shows), then
    Ctrl-C, and exit 0."""
    ready = block.directive("background")
    deadline = time.monotonic() + (BACKGROUND_READY_S if ready else BACKGROUND_S)
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise BlockFailed(f"{block.name}: ended by itself (exit {proc.returncode})")
        if ready and ready in _output(log):
            break
        time.sleep(0.5)
    else:
        if ready:
            raise BlockFailed(f"{block.name}: {ready!r} not shown in {BACKGROUND_READY_S:.0f} s")
    os.killpg(proc.pid, signal.SIGINT)  # Ctrl-C
    _exits_0(block, proc, BACKGROUND_STOP_S, " after Ctrl-C")


def _exits_0(block: Block, proc: subprocess.Popen[bytes], timeout: float, when: str) -> None:
    try:
        code = proc.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        raise BlockFailed(f"{block.name}: still running {timeout:.0f} s{when}") from None
    if code != 0:
        raise BlockFailed(f"{block.name}: exit {code}{when}")


def run_block(block: Block, cwd: Path, env: dict[str, str], log: Path) -> None:
    """Run ``block`` in ``cwd`` as bash would run it pasted (stopping at the first failing
    command), its output in ``log``; raise :class:`BlockFailed` unless it did what it says.
    Whatever it leaves running is stopped."""
    with log.open("wb") as out:
        # A file, not a pipe: a block's `&` jobs would hold a pipe open after it ends.
        proc = subprocess.Popen(
            [*DEFAULT_SIGINT, "bash", "-e", "-o", "pipefail", "-c", block.text],
            cwd=cwd,
            env=env,
            stdin=subprocess.DEVNULL,
            stdout=out,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
        try:
            if block.directive("background") is not None:
                _stop_on_ctrl_c(block, proc, log)
                return
            _exits_0(block, proc, TIMEOUT_S, " after its start")
        finally:
            _stop_group(proc)


@pytest.mark.parametrize("block", _params(RUN_BLOCKS))
def test_command_block_runs_as_written(block: Block, tmp_path: Path, ros_domain_id: int) -> None:
    if ROS_COMMAND.search(block.text) and importlib.util.find_spec("rclpy") is None:
        pytest.skip("needs rclpy (the ros extra)")
    scratch = scratch_copy(tmp_path / "repo")
    log = tmp_path / "output.txt"
    try:
        run_block(block, scratch, _environment(scratch, ros_domain_id), log)
    except BlockFailed as exc:
        pytest.fail(f"{exc}\n--- the block:\n{block.text}--- its output:\n{_tail(log)}")
    print(_tail(log))  # shown with -s or -rP: what the block printed


@pytest.mark.parametrize("block", _params(RUN_PYTHON))
def test_python_block_runs_as_written(block: Block, tmp_path: Path, ros_domain_id: int) -> None:
    scratch = scratch_copy(tmp_path / "repo")
    (scratch / "block.py").write_text(as_script(block), encoding="utf-8")
    log = tmp_path / "output.txt"
    script = _made_up("python block.py\n")
    try:
        run_block(script, scratch, _environment(scratch, ros_domain_id), log)
    except BlockFailed as exc:
        pytest.fail(f"{exc}\n--- the script:\n{as_script(block)}--- its output:\n{_tail(log)}")


def quoted_in(block: Block, source: Path) -> bool:
    """Whether ``block``'s lines are consecutive lines of ``source``, up to indentation."""
    want = block.text.rstrip("\n")
    lines = source.read_text(encoding="utf-8").splitlines()
    n = len(want.splitlines())
    return any(
        textwrap.dedent("\n".join(lines[i : i + n])) == want for i in range(len(lines) - n + 1)
    )


@pytest.mark.parametrize("block", [pytest.param(b, id=b.name) for b in EXCERPTS])
def test_a_quoted_excerpt_is_still_in_its_source(block: Block) -> None:
    source = ROOT / (block.directive("excerpt") or "")
    assert source.is_file(), f"{block.name}: no file {source}"
    assert quoted_in(block, source), f"{block.name} no longer matches {source}"


# --- the runner itself, on blocks made up here -------------------------------------------------


def _made_up(text: str, *directives: str) -> Block:
    return Block(ROOT / "made-up.md", 1, "sh", text, directives)


def _isolated_env() -> dict[str, str]:
    return {**os.environ, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "ROS_STATIC_PEERS": ""}


def test_a_failing_command_fails_its_block_and_stops_it(tmp_path: Path) -> None:
    block = _made_up("echo one > one.txt\nfalse\necho two > two.txt\n")
    with pytest.raises(BlockFailed, match="exit 1"):
        run_block(block, tmp_path, _isolated_env(), tmp_path / "log")
    assert (tmp_path / "one.txt").exists()
    assert not (tmp_path / "two.txt").exists()


def test_a_failing_command_inside_a_pipe_fails_its_block(tmp_path: Path) -> None:
    with pytest.raises(BlockFailed, match="exit 3"):
        run_block(_made_up("(exit 3) | cat\n"), tmp_path, _isolated_env(), tmp_path / "log")


def test_a_background_block_must_keep_running_and_stop_cleanly(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(sys.modules[__name__], "BACKGROUND_READY_S", 3.0)
    env, log = _isolated_env(), tmp_path / "log"
    with pytest.raises(BlockFailed, match="ended by itself"):
        run_block(_made_up("echo ready\n", "background: ready"), tmp_path, env, log)
    with pytest.raises(BlockFailed, match="after Ctrl-C"):  # Ctrl-C ends it with 130
        run_block(_made_up("echo ready\nsleep 60\n", "background: ready"), tmp_path, env, log)
    with pytest.raises(BlockFailed, match="not shown"):
        run_block(_made_up("sleep 60\n", "background: ready"), tmp_path, env, log)
    serving = "trap 'exit 0' INT\necho ready\nsleep 60 &\nwait\n"
    run_block(_made_up(serving, "background: ready"), tmp_path, env, log)


def test_what_a_block_leaves_running_is_stopped(tmp_path: Path) -> None:
    run_block(_made_up("sleep 300 &\necho $! > pid\n"), tmp_path, _isolated_env(), tmp_path / "log")
    pid = int((tmp_path / "pid").read_text())
    stat = Path(f"/proc/{pid}/stat")
    # Gone, or a zombie waiting for its new parent to reap it.
    assert not stat.exists() or stat.read_text().rpartition(")")[2].split()[0] == "Z"


def test_an_excerpt_that_drifted_from_its_source_is_caught(tmp_path: Path) -> None:
    source = tmp_path / "src.py"
    source.write_text("def f():\n    a = 1\n    return a\n", encoding="utf-8")
    quoted = Block(ROOT / "made-up.md", 1, "python", "a = 1\nreturn a\n", ("excerpt: src.py",))
    drifted = Block(ROOT / "made-up.md", 1, "python", "a = 2\nreturn a\n", ("excerpt: src.py",))
    assert quoted_in(quoted, source)
    assert not quoted_in(drifted, source)
