"""The tables of docs/disturbances.md.

    python tests/disturbance_comparison.py run MISSION [PATH=VALUE ...]
    python tests/disturbance_comparison.py campaign CAMPAIGN [FIGURE.png]

``run`` runs a mission once with fields overridden by dotted path (as
``--set`` does; VALUE is YAML) and prints one Markdown row of its metrics,
ending with the thresholds its verdict missed. ``campaign`` reads the
campaign's mission, ``runs``, ``seed`` and its ``grid`` axes (dotted mission
paths, as ``wmr-mission sweep`` does), runs every cell ``runs`` times with
sensor seeds drawn from ``SeedSequence(seed)``, and prints one Markdown row
per cell: success rate, then medians over the runs of the estimation RMS
(position and heading, whole run), the RMS distance from the reference point
in the first (track) phase and the input jitter (RMS of the change of omega
from one sample to the next), then the thresholds missed most often (in how
many of the runs). The outcome and the thresholds are the product's verdict
(docs/mission-format.md, "Verdicts"). Kept beside the tests: it is a
measurement of the product, not part of it.
"""

from __future__ import annotations

import collections
import copy
import itertools
import sys
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from wmr_mission.output.result import RunResult
from wmr_mission.record import Outcome
from wmr_mission.sim.runner import run_mission
from wmr_mission.spec.loader import load_mission_text
from wmr_mission.spec.models import Mission
from wmr_mission.verdicts.metrics import summarize


def set_path(data: dict[str, Any], path: str, value: Any) -> None:
    *parents, last = path.split(".")
    for key in parents:
        data = data.setdefault(key, {})
    data[last] = copy.deepcopy(value)


def overridden(mission_file: Path, settings: list[str]) -> Mission:
    data = yaml.safe_load(mission_file.read_text(encoding="utf-8"))
    for setting in settings:
        path, _, value = setting.partition("=")
        set_path(data, path, yaml.safe_load(value))
    return load_mission_text(yaml.safe_dump(data), str(mission_file))


def missed(result: RunResult) -> list[str]:
    """The thresholds the run's verdict missed, by metric (phases left out)."""
    return sorted({line.split(" = ")[0].split(": ")[-1] for line in _unmet(result)})


def _unmet(result: RunResult) -> list[str]:
    if result.outcome is not Outcome.expect_failed:
        return []
    return result.message.removeprefix("expectation not met: ").split("; ")


def metrics(result: RunResult) -> tuple[bool, float, float, float, float]:
    position = np.hypot(result.x - result.x_est, result.y - result.y_est)
    heading = np.angle(np.exp(1j * (result.theta - result.theta_est)))
    first = (result.phase == 0) & np.isfinite(result.x_ref)
    off_path = np.hypot(result.x - result.x_ref, result.y - result.y_ref)[first]
    return (
        result.outcome == Outcome.success,
        float(np.sqrt(np.mean(position**2))),
        float(np.sqrt(np.mean(heading**2))),
        float(np.sqrt(np.mean(off_path**2))) if off_path.size else float("nan"),
        float(np.sqrt(np.mean(np.diff(result.omega) ** 2))),
    )


def label(value: Any) -> str:
    if isinstance(value, dict) and "type" in value:
        gate = value.get("innovation_gate")
        return str(value["type"]) + ("" if gate is None else f" (gate {gate:g})")
    return str(value)


def run_row(mission_path: str, settings: list[str]) -> None:
    result = run_mission(overridden(Path(mission_path), settings))
    summary = summarize(result)
    _, position, heading, tracking, jitter = metrics(result)
    final = summary["final"]["position_error"]
    print(
        f"| {' '.join(settings) or '(none)'} | {result.outcome.value} | {summary['duration']:g} "
        f"| {final:.3g} | {position:.3g} | {heading:.3g} | {tracking:.3g} | {jitter:.3g} "
        f"| {', '.join(missed(result)) or '-'} |"
    )


def campaign_table(campaign_path: str, figure: str | None = None) -> None:
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
        "| off the reference point, RMS [m] | omega jitter [rad/s] | missed most (runs) |"
    )
    print("|" + "---|" * (len(axes) + 6))
    cells = []
    for cell in itertools.product(*axes.values()):
        data = copy.deepcopy(base)
        for path, value in zip(axes, cell, strict=True):
            set_path(data, path, value)
        mission = load_mission_text(yaml.safe_dump(data), str(mission_file))
        results = [run_mission(mission, seed=seed) for seed in seeds]
        rows = np.array([metrics(result) for result in results])
        misses = collections.Counter(m for result in results for m in missed(result))
        most = ", ".join(f"{m} ({n})" for m, n in misses.most_common(2)) or "-"
        success = rows[:, 0].mean()
        medians = np.nanmedian(rows[:, 1:], axis=0)
        values = " | ".join(f"{m:.3g}" for m in medians)
        print(
            f"| {' | '.join(label(v) for v in cell)} | {success:.0%} | {values} | {most} |",
            flush=True,
        )
        cells.append((cell, success, medians))
    if figure is not None:
        draw(cells, list(axes), figure)


def draw(cells: list[tuple[Any, float, np.ndarray]], axes: list[str], path: str) -> None:
    """Median estimation and tracking RMS against the first axis, a line per second-axis value."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, panels = plt.subplots(1, 3, figsize=(13, 4))
    lines: dict[str, list[tuple[float, float, np.ndarray]]] = {}
    for cell, success, medians in cells:
        lines.setdefault(label(cell[1]), []).append((float(cell[0]), success, medians))
    for name, points in lines.items():
        x = [p[0] for p in points]
        panels[0].plot(x, [100 * p[1] for p in points], marker="o", label=name)
        panels[1].plot(x, [p[2][0] for p in points], marker="o", label=name)
        panels[2].plot(x, [p[2][2] for p in points], marker="o", label=name)
    titles = ("success [%]", "estimation RMS, position [m]", "tracking RMS [m]")
    for panel, title in zip(panels, titles, strict=True):
        panel.set_title(title)
        panel.set_xlabel(axes[0])
        panel.grid(True, linewidth=0.4, alpha=0.5)
    panels[1].set_yscale("log")
    panels[2].set_yscale("log")
    panels[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)


if __name__ == "__main__":
    if sys.argv[1] == "run":
        run_row(sys.argv[2], sys.argv[3:])
    else:
        campaign_table(sys.argv[2], sys.argv[3] if len(sys.argv) > 3 else None)
