"""Judge the same simulated runs with two versions of the judge; compare them.

    python scripts/same_verdicts.py runs RUNS.pickle        # simulate the runs once
    python scripts/same_verdicts.py judge RUNS.pickle OUT.json
    python scripts/same_verdicts.py compare BEFORE.json AFTER.json

``runs``: every mission in missions/ and tests/data/generated, and the
first ten draws of each campaign in missions/campaigns/, each simulated
once and pickled. ``judge``: each run
judged as ``run`` judges it (``judge``: summary.json less its two timings)
and as a campaign's row does (``judge_run_metrics``), under its mission and
under the same with tight thresholds (so that checks miss, and the row
measures its tracking error again), every float written with ``repr``: the
same text is the same bits. With ``WMR_MISSION_NO_JIT=1`` the judge runs as
plain Python; else with its compiled passes (the samples judged counted past
``JUDGED_COMPILED_FROM``). ``compare``: each run whose verdicts differ; exit 1
if any.

For a change to the judge that must not change a number: judge with the
package before it (on ``PYTHONPATH``) and after, compiled and plain, and
compare.
"""

from __future__ import annotations

import copy
import json
import os
import pickle
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
# What summary.json records of how fast the run went: not a verdict.
TIMES = ("compute_us_per_sample", "loop_us_per_sample")
# Thresholds a run of most missions misses somewhere.
TIGHT = {
    "cross_track_error_max": {"max": 0.002},
    "tracking_error_max": {"max": 0.003},
    "tracking_error_rms": {"max": 0.001},
    "speed_jump_max": {"max": 0.5},
    "clearance_min": 0.05,
    "estimation_rms": {"x": 0.001, "theta": 0.002},
}
DRAWS = 10


def simulate(out: Path) -> None:
    from wmr_mission.campaign.load import load_campaign
    from wmr_mission.campaign.plan import Plan
    from wmr_mission.campaign.rows import mission_of
    from wmr_mission.sim.plan import plan_mission
    from wmr_mission.sim.runner import run_mission
    from wmr_mission.spec.loader import load_mission

    runs = []
    for folder in ("missions", "tests/data/generated"):
        for path in sorted((ROOT / folder).glob("*.yaml")):
            mission = load_mission(path)
            result = run_mission(plan_mission(mission))
            runs.append((f"{folder}/{path.name}", result, mission.model_dump(mode="json")))
    for path in sorted((ROOT / "missions" / "campaigns").glob("*.yaml")):
        loaded = load_campaign(path)
        plan = Plan(loaded.campaign)
        for run in range(1, min(loaded.campaign.runs, DRAWS) + 1):
            draw = plan.draw(run)
            mission, _ = mission_of(loaded, draw)
            if mission is not None:
                result = run_mission(plan_mission(mission, draw.seed))
                runs.append((f"{path.stem}#{run}", result, mission.model_dump(mode="json")))
    with open(out, "wb") as file:
        pickle.dump(runs, file)
    print(f"{len(runs)} runs in {out}")


def _text(value: Any) -> Any:
    """``value`` with every float as its repr: equal text, equal bits."""
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, dict):
        return {str(k): _text(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_text(v) for v in value]
    return value


def judged(runs_file: Path, out: Path) -> None:
    from wmr_mission.kernels import jit
    from wmr_mission.verdicts.metrics import judge, judge_run_metrics

    if os.environ.get(jit.NO_JIT) != "1":
        jit.load()
        jit.judged(jit.JUDGED_COMPILED_FROM)
    with open(runs_file, "rb") as file:
        runs = pickle.load(file)
    found = {}
    for name, result, mission in runs:
        tight = copy.deepcopy(mission)
        tight["expect"] = {**(tight.get("expect") or {}), **TIGHT}
        for label, terms in ((name, mission), (f"{name} (tight)", tight)):
            as_run, as_row = replace(result), replace(result)
            summary = judge(as_run, terms)
            for key in TIMES:
                summary.pop(key, None)
            row = judge_run_metrics(as_row, terms)
            outcomes = [as_run.outcome.value, as_run.message, as_row.outcome.value, as_row.message]
            found[label] = _text({"summary": summary, "row": row, "outcomes": outcomes})
    out.write_text(json.dumps(found, indent=1, sort_keys=True), encoding="utf-8")
    mode = "plain Python" if os.environ.get(jit.NO_JIT) == "1" else "compiled"
    print(f"{len(found)} verdicts ({mode}) in {out}")


def compare(before: Path, after: Path) -> int:
    old = json.loads(before.read_text(encoding="utf-8"))
    new = json.loads(after.read_text(encoding="utf-8"))
    differing = [name for name in sorted(old.keys() | new.keys()) if old.get(name) != new.get(name)]
    for name in differing:
        print(f"{name}: differs")
    print(f"{len(old.keys() | new.keys()) - len(differing)} the same, {len(differing)} differ")
    return 1 if differing else 0


def main(arguments: list[str]) -> int:
    if arguments[:1] == ["runs"] and len(arguments) == 2:
        simulate(Path(arguments[1]))
    elif arguments[:1] == ["judge"] and len(arguments) == 3:
        judged(Path(arguments[1]), Path(arguments[2]))
    elif arguments[:1] == ["compare"] and len(arguments) == 3:
        return compare(Path(arguments[1]), Path(arguments[2]))
    else:
        print(__doc__, file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
