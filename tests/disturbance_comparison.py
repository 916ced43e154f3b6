"""The table of docs/disturbances.md: a grid campaign run in one process.

    python tests/disturbance_comparison.py missions/campaigns/estimators-disturbances.yaml

Reads the campaign's mission, ``runs``, ``seed`` and its ``grid`` axes
(dotted mission paths, as ``wmr-mission sweep`` does), runs every cell
``runs`` times with sensor seeds drawn from ``SeedSequence(seed)``, and
prints one Markdown row per cell: success rate, then medians over the runs
of the estimation RMS (position and heading, whole run), the tracking RMS of
the first (track) phase and the input jitter (RMS of the change of omega
from one sample to the next). Kept beside the tests: it is a measurement of
the product, not part of it.
"""

from __future__ import annotations

import copy
import itertools
import sys
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from wmr_mission.output.metrics import summarize
from wmr_mission.result import Outcome, RunResult
from wmr_mission.runner import run_mission
from wmr_mission.spec.loader import load_mission_text


def set_path(data: dict[str, Any], path: str, value: Any) -> None:
    *parents, last = path.split(".")
    for key in parents:
        data = data.setdefault(key, {})
    data[last] = copy.deepcopy(value)


def metrics(result: RunResult) -> tuple[bool, float, float, float, float]:
    position = np.hypot(result.x - result.x_est, result.y - result.y_est)
    heading = np.angle(np.exp(1j * (result.theta - result.theta_est)))
    tracking = summarize(result)["phases"][0]["tracking_error"]
    return (
        result.outcome == Outcome.success,
        float(np.sqrt(np.mean(position**2))),
        float(np.sqrt(np.mean(heading**2))),
        float("nan") if tracking is None else float(tracking["rms"]),
        float(np.sqrt(np.mean(np.diff(result.omega) ** 2))),
    )


def label(value: Any) -> str:
    if isinstance(value, dict) and "type" in value:
        gate = value.get("innovation_gate")
        return str(value["type"]) + ("" if gate is None else f" (gate {gate:g})")
    return str(value)


def main(campaign_path: str) -> None:
    campaign_file = Path(campaign_path)
    campaign = yaml.safe_load(campaign_file.read_text(encoding="utf-8"))
    mission_file = campaign_file.parent / campaign["mission"]
    base = yaml.safe_load(mission_file.read_text(encoding="utf-8"))
    axes = {path: spec["grid"] for path, spec in campaign["vary"].items()}
    runs = int(campaign["runs"])
    seeds = [
        int(child.generate_state(1)[0])
        for child in np.random.SeedSequence(campaign["seed"]).spawn(runs)
    ]
    print(
        f"| {' | '.join(axes)} | success | est. position RMS [m] | est. heading RMS [rad] "
        "| tracking RMS [m] | omega jitter [rad/s] |"
    )
    print("|" + "---|" * (len(axes) + 5))
    for cell in itertools.product(*axes.values()):
        data = copy.deepcopy(base)
        for path, value in zip(axes, cell, strict=True):
            set_path(data, path, value)
        mission = load_mission_text(yaml.safe_dump(data), str(mission_file))
        rows = np.array([metrics(run_mission(mission, seed=seed)) for seed in seeds])
        success = rows[:, 0].mean()
        medians = np.nanmedian(rows[:, 1:], axis=0)
        values = " | ".join(f"{m:.3g}" for m in medians)
        print(f"| {' | '.join(label(v) for v in cell)} | {success:.0%} | {values} |", flush=True)


if __name__ == "__main__":
    main(sys.argv[1])
