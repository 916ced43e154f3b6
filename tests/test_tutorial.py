"""docs/tutorial.md runs as written: every block in order, from an empty directory.

The tutorial's blocks are read by their fence:

* ```` ```yaml ```` writes the file named (in backticks, ending ``.yaml``) last
  in the paragraph before it;
* ```` ```console ```` holds commands (``$ ...``), each followed by what it
  prints; a command must exit 0 unless its printout ends with ``(exit N)``;
* ```` ```python ```` runs as a script; a ```` ```text ```` block right after it
  is what it prints.

A printout is matched line by line, in order, each expected line against some
later line of what was printed (stdout, then stderr), spaces at the ends
ignored; ``…`` in an expected line stands for any text. So the numbers the
tutorial shows are the numbers a reader gets.

The commands run as a reader's: with the compiled loop where the kernel
cache holds it and is marked ready (after a whole-suite run's compile first,
by ``wmr-mission compile``: tests/conftest.py), the sweep and the
longer runs compiled, 13 s of CPU; in a cache not ready, `run` as plain
Python and the sweep compiling its loop (``WMR_MISSION_NO_JIT=1`` in the
environment: all as plain Python, 35 s).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

TUTORIAL = Path(__file__).resolve().parent.parent / "docs" / "tutorial.md"
EXIT = re.compile(r"^\(exit (\d+)\)$")


@dataclass(frozen=True)
class Block:
    kind: str  # yaml, console, python, text
    text: str
    before: str  # the paragraph of text right before the block
    line: int  # where the block starts in the tutorial


def blocks(markdown: str) -> list[Block]:
    found: list[Block] = []
    lines = markdown.splitlines()
    before = ""
    k = 0
    while k < len(lines):
        fence = re.match(r"^```(\w*)\s*$", lines[k])
        if fence is None:
            if lines[k].strip():
                before = f"{before} {lines[k]}".strip()
            elif k + 1 < len(lines) and not lines[k + 1].startswith("```"):
                before = ""  # a blank line ends a paragraph, unless a block follows
            k += 1
            continue
        end = lines.index("```", k + 1)
        found.append(Block(fence.group(1), "\n".join(lines[k + 1 : end]) + "\n", before, k + 1))
        before = ""
        k = end + 1
    return found


def commands(block: Block) -> list[tuple[str, list[str]]]:
    """(command, expected printout) of each ``$ `` line of a console block."""
    found: list[tuple[str, list[str]]] = []
    for line in block.text.splitlines():
        if line.startswith("$ "):
            found.append((line[2:], []))
        else:
            assert found, f"tutorial.md:{block.line}: a console block starts with '$ '"
            found[-1][1].append(line)
    return found


def _matches(expected: str, actual: str) -> bool:
    pattern = ".*".join(re.escape(part) for part in expected.strip().split("…"))
    return re.fullmatch(pattern, actual.strip()) is not None


def check_printout(where: str, expected: list[str], printed: str) -> None:
    wanted = [line for line in expected if line.strip()]
    actual = printed.splitlines()
    at = 0
    for line in wanted:
        while at < len(actual) and not _matches(line, actual[at]):
            at += 1
        assert at < len(actual), f"{where}: not printed: {line!r}\n--- printed:\n{printed}"
        at += 1


def _environment() -> dict[str, str]:
    bin_dir = str(Path(sys.executable).parent)
    return {
        **os.environ,
        "PATH": bin_dir + os.pathsep + os.environ.get("PATH", ""),
        "COLUMNS": "100",
        "MPLBACKEND": "Agg",
    }


@pytest.mark.slow
def test_the_tutorial_runs_as_written(tmp_path: Path) -> None:
    environment = _environment()
    written: list[str] = []
    pending_python: str | None = None
    for block in blocks(TUTORIAL.read_text(encoding="utf-8")):
        where = f"docs/tutorial.md:{block.line}"
        if block.kind == "yaml":
            names = re.findall(r"`([\w./-]+\.yaml)`", block.before)
            assert names, f"{where}: a yaml block follows a line naming its file"
            (tmp_path / names[-1]).write_text(block.text, encoding="utf-8")
            written.append(names[-1])
        elif block.kind == "console":
            for command, expected in commands(block):
                code = 0
                if expected and EXIT.match(expected[-1].strip()):
                    code = int(EXIT.match(expected[-1].strip()).group(1))  # type: ignore[union-attr]
                    expected = expected[:-1]
                done = subprocess.run(
                    ["bash", "-c", command],
                    cwd=tmp_path,
                    env=environment,
                    capture_output=True,
                    text=True,
                    timeout=300,
                )
                printed = done.stdout + done.stderr
                assert done.returncode == code, (
                    f"{where}: $ {command}: exit {done.returncode}\n{printed}"
                )
                check_printout(f"{where}: $ {command}", expected, printed)
        elif block.kind == "python":
            pending_python = block.text
            done = subprocess.run(
                [sys.executable, "-c", block.text],
                cwd=tmp_path,
                env=environment,
                capture_output=True,
                text=True,
                timeout=300,
            )
            assert done.returncode == 0, f"{where}: the script failed\n{done.stderr}"
            pending_python = done.stdout + done.stderr
            continue
        elif block.kind == "text":
            assert pending_python is not None, f"{where}: a text block follows a python block"
            check_printout(where, block.text.splitlines(), pending_python)
        pending_python = None
    assert written, "the tutorial writes its missions"


def test_the_harness_reads_blocks_and_matches_printouts() -> None:
    markdown = (
        "Write `b.yaml`:\n\nthen `a.yaml`, a file\nof two lines:\n\n```yaml\nversion: 1\n```\n\n"
        "```console\n$ run a\nok …\n(exit 1)\n```\n"
    )
    yaml_block, console = blocks(markdown)
    assert (yaml_block.kind, yaml_block.before, yaml_block.text) == (
        "yaml",
        "then `a.yaml`, a file of two lines:",
        "version: 1\n",
    )
    assert commands(console) == [("run a", ["ok …", "(exit 1)"])]
    check_printout("x", ["first …", "third"], "first line\nsecond\n  third  \n")
    with pytest.raises(AssertionError, match="not printed: 'second'"):
        check_printout("x", ["third", "second"], "first\nsecond\nthird\n")
