"""A command's use of the machine's cores, second by second: where a long
command (the README's test command) leaves a core idle, for docs/performance.md.

    python benchmarks/cpu_timeline.py OUT -- COMMAND ...

Runs COMMAND, and each second appends to OUT the seconds since the start,
the cores busy over that second (from /proc/stat: 2.00 is both of two cores),
and the command line of the process that used most of it. Linux only.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time


def _busy_and_total() -> tuple[int, int]:
    with open("/proc/stat", encoding="ascii") as stat:
        ticks = [int(field) for field in stat.readline().split()[1:]]
    idle = ticks[3] + ticks[4]  # idle and iowait
    return sum(ticks) - idle, sum(ticks)


def main() -> int:
    out, command = sys.argv[1], sys.argv[sys.argv.index("--") + 1 :]
    cores = os.cpu_count() or 1  # /proc/stat's first line sums them all
    started = time.monotonic()
    process = subprocess.Popen(command)
    before = _busy_and_total()
    with open(out, "w", encoding="utf-8") as timeline:
        while process.poll() is None:
            time.sleep(1.0)
            now = _busy_and_total()
            busy = cores * (now[0] - before[0]) / max(1, now[1] - before[1])
            before = now
            top = subprocess.run(
                ["ps", "-eo", "pcpu,args", "--sort=-pcpu", "--no-headers"],
                capture_output=True,
                text=True,
                check=False,
            ).stdout.splitlines()[:1]
            seconds = time.monotonic() - started
            timeline.write(f"{seconds:6.0f} {busy:4.2f} | {' '.join(top)[:120]}\n")
            timeline.flush()
    return process.returncode


if __name__ == "__main__":
    sys.exit(main())
