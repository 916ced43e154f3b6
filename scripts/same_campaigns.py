"""Sweep every shipped campaign into a directory; compare two such directories.

    python scripts/same_campaigns.py sweep DIR [CAMPAIGN.yaml ...]
    python scripts/same_campaigns.py compare BEFORE AFTER

``sweep``: each campaign (by default every missions/campaigns/*.yaml) is swept
with ``--no-plots`` on 1 and on 2 workers by the package this Python imports,
into DIR/NAME-WORKERS. ``compare``: byte for byte, ``runs.csv``,
``campaign.json`` less the times it records (``wall_seconds``,
``missions_per_second``, ``startup_seconds``), and every file of each worst
run's directory less those that record when and how fast it ran
(manifest.json, and summary.json's ``compute_us_per_sample`` and
``loop_us_per_sample``); prints each difference,
exit 1 if any. For a change to how a campaign runs that must not change what
it gives: sweep with the code before it (``git stash``, same checkout, so
that the compiled kernels are the cache's), then after, then compare.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
# What campaign.json and a run's summary.json record of how fast it ran.
TIMES = (
    "wall_seconds",
    "missions_per_second",
    "startup_seconds",
    "compute_us_per_sample",
    "loop_us_per_sample",
)
# Files of a run directory that record when, where and how fast it ran.
RUN_RECORDS = {"manifest.json"}


def _sweep(campaign: Path, out: Path, workers: int) -> None:
    command = [sys.executable, "-m", "wmr_mission", "sweep", str(campaign), "--no-plots"]
    command += ["--workers", str(workers), "--out", str(out)]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode not in (0, 1):  # 1: an expect not met, still a campaign
        raise RuntimeError(f"{' '.join(command)}: exit {done.returncode}\n{done.stderr}")


def _without_times(data: Any) -> Any:
    if isinstance(data, dict):
        return {k: _without_times(v) for k, v in data.items() if k not in TIMES}
    if isinstance(data, list):
        return [_without_times(v) for v in data]
    return data


def _compared(path: Path) -> bytes:
    if path.name == "campaign.json" or path.name == "summary.json":
        data = json.loads(path.read_text(encoding="utf-8"))
        return json.dumps(_without_times(data), sort_keys=True).encode()
    return path.read_bytes()


def differences(before: Path, after: Path) -> list[str]:
    """Each file that differs between two campaign directories, or is in one only."""
    names = {
        p.relative_to(root)
        for root in (before, after)
        for p in root.rglob("*")
        if p.is_file() and p.name not in RUN_RECORDS
    }
    found = []
    for name in sorted(names):
        old, new = before / name, after / name
        if not (old.is_file() and new.is_file()):
            found.append(f"{name}: only in {'the first' if old.is_file() else 'the second'}")
        elif _compared(old) != _compared(new):
            found.append(f"{name}: differs")
    return found


def sweep(directory: Path, campaigns: list[Path]) -> None:
    directory.mkdir(parents=True, exist_ok=True)
    for campaign in campaigns:
        for workers in (1, 2):
            _sweep(campaign.resolve(), directory / f"{campaign.stem}-{workers}", workers)
            print(f"{campaign.name}, {workers} worker(s): swept", flush=True)


def compare(before: Path, after: Path) -> int:
    failed = 0
    for old in sorted(p for p in before.iterdir() if p.is_dir()):
        found = differences(old, after / old.name)
        print(f"{old.name}: {'same' if not found else f'{len(found)} files differ'}")
        for line in found:
            print(f"  {line}")
        failed += bool(found)
    return 1 if failed else 0


if __name__ == "__main__":
    if len(sys.argv) >= 3 and sys.argv[1] == "sweep":
        given = [Path(p) for p in sys.argv[3:]]
        sweep(Path(sys.argv[2]), given or sorted((ROOT / "missions" / "campaigns").glob("*.yaml")))
    elif len(sys.argv) == 4 and sys.argv[1] == "compare":
        sys.exit(compare(Path(sys.argv[2]), Path(sys.argv[3])))
    else:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
