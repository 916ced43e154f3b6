"""The README's test command timed as a new contributor runs it, for
docs/performance.md ("The test suite"): commits in turn, each in a fresh
clone, an empty kernel cache and pip's and uv's caches off.

    python benchmarks/readme_command.py [--extras test] COMMIT [COMMIT ...]

Each COMMIT (repeat one to run it again: ``A B B A`` is two pairs) is cloned
from this checkout into a temporary directory; the line `.ci/run` runs, the
second fenced command of the README's "## Quick start", is run there with
``bash -c``, its output kept in ``readme-N-COMMIT.log`` here. ``--extras``
puts other extras in place of the line's ``[test,irsim,ros2]`` (``test``:
without the backends' tests). Prints per run its wall time, the CPU of the
command and every process it waited for (user + system), and pytest's last
line. Run it with nothing else running: the times are the machine's.
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
EXTRAS = "[test,irsim,ros2]"


def test_line(readme: str) -> str:
    """The README's test command as `.ci/run` reads it: the second line inside
    the fences after "## Quick start" (each of its two commands is one line)."""
    fenced, inside, started = [], False, False
    for line in readme.splitlines():
        started = started or line.startswith("## Quick start")
        if not started:
            continue
        if line.startswith("```"):
            inside = not inside
        elif inside:
            fenced.append(line)
    if len(fenced) < 2:
        raise SystemExit("README.md: no test command under '## Quick start'")
    return fenced[1]


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run(commit: str, extras: str | None, log: Path) -> tuple[float, float, str]:
    """The README's test command at ``commit``: (wall s, CPU s, pytest's last line)."""
    with tempfile.TemporaryDirectory(prefix="readme-") as tmp:
        clone = Path(tmp) / "clone"
        subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
        subprocess.run(["git", "-C", str(clone), "checkout", "-q", commit], check=True)
        line = test_line((clone / "README.md").read_text(encoding="utf-8"))
        if extras is not None:
            line = line.replace(EXTRAS, f"[{extras}]")
        env = {**os.environ, "PIP_NO_CACHE_DIR": "1", "UV_NO_CACHE": "1"}
        env["NUMBA_CACHE_DIR"] = str(Path(tmp) / "kernels")
        cpu, started = _children_cpu(), time.monotonic()
        with log.open("w", encoding="utf-8") as out:
            out.write(f"+ {line}\n")
            out.flush()
            done = subprocess.run(
                ["bash", "-c", line], cwd=clone, env=env, stdout=out, stderr=subprocess.STDOUT
            )
        wall, cpu = time.monotonic() - started, _children_cpu() - cpu
        shutil.rmtree(clone, ignore_errors=True)
    lines = [t for t in log.read_text(encoding="utf-8").splitlines() if " in " in t]
    summary = next((t for t in reversed(lines) if "passed" in t or "failed" in t), "")
    if done.returncode != 0:
        summary = f"exit {done.returncode}: {summary}"
    return wall, cpu, summary.strip("= ")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("commits", nargs="+", metavar="COMMIT")
    parser.add_argument("--extras", help="extras in place of test,irsim,ros2 (e.g. test)")
    arguments = parser.parse_args()
    for number, commit in enumerate(arguments.commits, 1):
        log = Path(f"readme-{number}-{commit}.log")
        wall, cpu, summary = run(commit, arguments.extras, log)
        minutes, seconds = divmod(round(wall), 60)
        print(f"{commit}: {minutes} min {seconds:02d} s, {cpu:.0f} s of CPU; {summary}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
