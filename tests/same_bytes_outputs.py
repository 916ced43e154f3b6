"""The bytes a run and a campaign write, less the wall-clock times, as one
mapping ``file -> text``: what tests/test_same_bytes.py compares between
processes at different SIMD levels.

    python tests/same_bytes_outputs.py OUT_DIR MISSION.yaml ... CAMPAIGN.yaml ...

prints the mapping as JSON (a file is a campaign when it names a mission).
"""

from __future__ import annotations

import contextlib
import json
import sys
from pathlib import Path
from typing import Any

import yaml

# Wall-clock measurements: the only values a run may change from one process to the next.
TIMES = (
    "compute_us_per_sample",
    "loop_us_per_sample",
    "wall_seconds",
    "startup_seconds",
    "missions_per_second",
)


def _without_times(text: str) -> str:
    record = json.loads(text)
    for key in TIMES:
        record.pop(key, None)
    return json.dumps(record, indent=1, sort_keys=True)


def _directory(directory: Path, label: str) -> dict[str, str]:
    found = {}
    for path in sorted(directory.rglob("*")):
        name = f"{label}/{path.relative_to(directory)}"
        if path.name in ("trajectory.csv", "runs.csv", "transitions.json"):
            found[name] = path.read_text(encoding="utf-8")
        elif path.name in ("summary.json", "campaign.json"):
            found[name] = _without_times(path.read_text(encoding="utf-8"))
        elif path.name == "manifest.json":  # what decides the bytes, not where they were made
            environment = json.loads(path.read_text(encoding="utf-8"))["environment"]
            found[name] = f"{environment['fingerprint']} {environment['libm']}"
    return found


def outputs(out: Path, files: list[Path]) -> dict[str, str]:
    """Run each mission and campaign of ``files`` into ``out``; their bytes."""
    from wmr_mission.campaign.sweep import sweep_command
    from wmr_mission.output.rundir import write_run
    from wmr_mission.sim.runner import run_mission
    from wmr_mission.spec.loader import load_mission

    found: dict[str, str] = {}
    for path in files:
        directory = out / path.stem
        if "mission" in yaml.safe_load(path.read_text(encoding="utf-8")):
            # `sweep` as a user runs it; its report is not among the bytes compared
            with contextlib.redirect_stdout(sys.stderr):
                code = sweep_command(path, out=directory, workers=1, scheduler=None, plots=False)
            assert code == 0, f"{path}: sweep exited {code}"
        else:
            result = run_mission(load_mission(path))
            write_run(result, directory, plots=False, animate=False)
        found |= _directory(directory, path.stem)
    return found


def main(arguments: list[str]) -> None:
    found: Any = outputs(Path(arguments[0]), [Path(a) for a in arguments[1:]])
    print(json.dumps(found))


if __name__ == "__main__":
    main(sys.argv[1:])
