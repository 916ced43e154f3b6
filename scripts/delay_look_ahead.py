"""The paper's tracking law on a plant that answers late: which verdicts users'
missions with an input delay and an actuator lag miss with the default
look-ahead, and with a look-ahead derived from the delay and lag or from the
position noise written in (docs/paper-notes.md, "Eqs. (6)-(7) under position
noise": "A look-ahead from the delay and lag (tried, not kept)").

    python scripts/delay_look_ahead.py              # the users' missions
    python scripts/delay_look_ahead.py --runs       # and each run not a success
    python scripts/delay_look_ahead.py --generated  # the generated set, delayed
    python scripts/delay_look_ahead.py --shipped

The users' missions: a line along x, a diagonal line, a circle of radius 2 m
(15 s) and a square's three legs turned in place then a park, each at 0.3,
0.6 and 1.0 m/s (limits 1.5 m/s, 2 rad/s), with 0, 0.5, 1 and 2 cm of
position noise (10 mrad of heading noise where any), an input delay of 0, 30
or 60 ms and an actuator lag of 0, 50 or 100 ms; the estimator and every
verdict are the defaults. ``--generated`` adds a 30 ms delay (whole samples)
and a 50 ms lag to each mission of tests/data/generated/; ``--shipped`` runs
the shipped missions that state a delay and a lag: missions/disturbed.yaml
(levels 1 to 3) and missions/controllers.yaml (both paths, levels 1 and 2,
six headings, two seeds). Each rule writes its look-ahead only where the mission leaves it
unset, states disturbances, and the rule asks for more than the default;
prints the missed verdicts and the runs not a success per rule (``--runs``:
and each run not a success, named by its path, speed [m/s], noise [m], delay
and lag [s], or its file).
"""

from __future__ import annotations

import argparse
import itertools
import math
from collections import Counter
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import yaml

from wmr_mission import load_mission, mission_from_dict, run_mission
from wmr_mission.spec.models import Disturbances

ROOT = Path(__file__).resolve().parents[1]
GENERATED = ROOT / "tests" / "data" / "generated"
DT = 0.01
LIMITS = (1.5, 2.0)  # v [m/s], omega [rad/s]
# sqrt((1 - 0.9) / (1 + 0.9)): the share of the position noise an estimate at
# the estimators' own poles (0.9) passes on, kept under stated disturbances.
UNFILTERED = math.sqrt(0.1 / 1.9)
# The share of the turn-rate limit the estimate's noise may take as jitter
# (ControllerSettings.position_noise_budget).
JITTER_SHARE = 0.01

# A rule: (response [s], position noise [m], limits, time constant [s]) -> look-ahead [m]
Rule = Callable[[float, float, tuple[float, float], float], float]


def _response(response: float, noise: float, limits: tuple[float, float], tau: float) -> float:
    """The heading the law turns at v / l, a command acting ``response`` late:
    no overshoot while (v / l) response <= 1 / e, at the speed limit."""
    return math.e * limits[0] * response


def _noise(response: float, noise: float, limits: tuple[float, float], tau: float) -> float:
    """The controller's budget, JITTER_SHARE omega l tau, holding the noise an
    estimate at poles 0.9 passes on."""
    return UNFILTERED * noise / (JITTER_SHARE * limits[1] * tau)


RULES: dict[str, Rule | None] = {
    "default": None,
    "e limits.v (delay + lag)": _response,
    "noise budget": _noise,
    "both": lambda *numbers: max(_response(*numbers), _noise(*numbers)),
}


def _with_rule(data: dict[str, Any], rule: Rule | None) -> dict[str, Any]:
    """``data`` with the rule's look-ahead written in where the mission leaves
    it unset and the rule asks for more than the default."""
    mission = mission_from_dict(data)
    controller = mission.controller
    tracking = getattr(controller, "tracking", None)
    if rule is None or tracking is None or tracking.output == "axle" or tracking.look_ahead:
        return data
    robot = mission.robot
    if robot.disturbances == Disturbances.defaults():  # the estimator filters the noise
        return data
    limits = (float(robot.limits.v), float(robot.limits.omega))
    disturbances = robot.disturbances
    response = float(disturbances.input_delay) + float(disturbances.actuator_time_constant)
    noise = mission.sensors.measured_noise()
    sigma = max(noise.get("x", 0.0), noise.get("y", 0.0))
    tau = max(float(tracking.time_constant), float(robot.dt))
    distance = rule(response, sigma, limits, tau)
    if distance <= max(0.05, limits[0] * float(robot.dt)):
        return data
    written = dict(data)
    written["controller"] = {
        **(data.get("controller") or {}),
        "tracking": {**(data.get("controller") or {}).get("tracking", {}), "look_ahead": distance},
    }
    return written


def _users_mission(
    path: str, speed: float, noise: float, delay: float, lag: float
) -> dict[str, Any]:
    robot: dict[str, Any] = {"dt": DT, "limits": {"v": LIMITS[0], "omega": LIMITS[1]}}
    if delay or lag:
        robot["disturbances"] = {"input_delay": delay, "actuator_time_constant": lag}
    timeout = 20.0 + 9.0 / speed
    if path == "circle":
        robot["initial_state"] = {"x": 2, "y": 0, "theta": math.pi / 2}
        circle = {"type": "circle", "center": [0, 0], "radius": 2, "angular_rate": speed / 2}
        phases: list[dict[str, Any]] = [
            {
                "name": "circle",
                "track": {"path": {**circle, "start": "current"}},
                "until": {"elapsed": 15},
            }
        ]
    else:
        heading, end = {"line": (0.0, [5, 0]), "diagonal": (math.atan2(3, 4), [4, 3])}.get(
            path, (0.0, [0, 3])
        )
        robot["initial_state"] = {"x": 0, "y": 0, "theta": heading}
        way = {"type": "line", "towards": end, "speed": speed}
        if path == "corners":
            way = {"type": "polyline", "points": [[3, 0], [3, 3], [0, 3]], "speed": speed}
        phases = [
            {
                "name": "go",
                "track": {"path": way},
                "until": {"near": {"point": end, "tolerance": 0.05}},
                "timeout": timeout,
            }
        ]
        if path == "corners":
            park = {"target": {"x": 0, "y": 3, "theta": math.pi}}
            settled = {"settled": {"position": 0.05, "heading": 0.05}}
            phases.append({"name": "park", "regulate": park, "until": settled, "timeout": 20})
    data: dict[str, Any] = {"version": 1, "name": "user", "robot": robot, "phases": phases}
    if noise:
        std = {"x": noise, "y": noise, "theta": 0.01}
        data["sensors"] = {"measure": ["x", "y", "theta"], "noise_std": std, "seed": 5}
    return data


def users_missions() -> Iterator[tuple[str, dict[str, Any]]]:
    """(path speed noise delay lag, the mission) of each users' mission."""
    paths = ("line", "diagonal", "circle", "corners")
    for cell in itertools.product(
        paths, (0.3, 0.6, 1.0), (0.0, 0.005, 0.01, 0.02), (0.0, 0.03, 0.06), (0.0, 0.05, 0.1)
    ):
        yield " ".join(str(value) for value in cell), _users_mission(*cell)


def generated_missions() -> Iterator[tuple[str, dict[str, Any]]]:
    for path in sorted(GENERATED.glob("*.yaml")):
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
        robot = data.setdefault("robot", {})
        dt = float(robot.get("dt", DT))
        delay = round(0.03 / dt) * dt
        robot["disturbances"] = {"input_delay": delay, "actuator_time_constant": 0.05}
        yield path.stem, data


def _judged(job: tuple[dict[str, Any], str]) -> tuple[str, list[str]]:
    """The run's outcome and the metrics of its missed checks."""
    data, rule = job
    summary = run_mission(mission_from_dict(_with_rule(data, RULES[rule]))).summary()
    return summary["outcome"], [c["metric"] for c in summary["expectations"] if not c["met"]]


def _table(missions: list[tuple[str, dict[str, Any]]], runs: bool) -> None:
    """The table of the rules; with ``runs``, each run not a success first."""
    rows = []
    with ProcessPoolExecutor(2) as pool:
        for rule in RULES:
            jobs = [(mission, rule) for _, mission in missions]
            judged = list(pool.map(_judged, jobs, chunksize=4))
            missed = Counter(metric for _, metrics in judged for metric in metrics)
            failed = sum(outcome != "success" for outcome, _ in judged)
            most = ", ".join(f"{metric} {count}" for metric, count in missed.most_common(3))
            rows.append(f"| {rule} | {missed.total()} | {failed} of {len(judged)} | {most} |")
            for (name, _), (outcome, metrics) in zip(missions, judged, strict=True):
                if runs and outcome != "success":
                    print(f"{rule}: {name}: {outcome} {' '.join(metrics)}")
    print("| look-ahead | missed verdicts | runs not a success | the most missed |")
    print("|---|---|---|---|")
    print("\n".join(rows))


def controllers() -> None:
    """missions/controllers.yaml, the paper's controller, per path and level."""
    figure_eight = {"type": "expression", "x": "5.5 + 3*sin(0.5*t)", "y": "3*sin(0.5*t)*cos(0.5*t)"}
    # the tracking RMS and the jitter: means over the runs
    print("| path | level | look-ahead [m] | successes | tracking RMS [m] | jitter [rad/s] |")
    print("|---|---|---|---|---|---|")
    for path, level in itertools.product(("ellipse", "figure-eight"), (1, 2)):
        for rule in ("default", "e limits.v (delay + lag)"):
            overrides: dict[str, Any] = {"parameters.level": level}
            if path == "figure-eight":
                overrides["phases[0].track.path"] = figure_eight
            data = load_mission(ROOT / "missions" / "controllers.yaml", overrides).model_dump(
                mode="json"
            )
            data = _with_rule(data, RULES[rule])
            look_ahead = data["controller"]["tracking"]["look_ahead"] or 0.1
            rms, jitter, successes = [], [], 0
            for heading, seed in itertools.product((-2.5, -1.5, -0.5, 0.5, 1.5, 2.5), (0, 1)):
                data["robot"]["initial_state"]["theta"] = heading
                summary = run_mission(mission_from_dict(data), seed=seed).summary()
                values = {
                    c["metric"]: c["value"]
                    for c in summary["expectations"]
                    if c["phase"] == "track"
                }
                rms.append(values["tracking_error_rms"])
                jitter.append(values["turn_rate_jitter"])
                successes += summary["outcome"] == "success"
            print(
                f"| {path} | {level} | {look_ahead:.2f} | {successes} of {len(rms)} "
                f"| {sum(rms) / len(rms):.4f} | {sum(jitter) / len(jitter):.3f} |"
            )


def disturbed() -> None:
    """missions/disturbed.yaml at levels 1 to 3 (its seed)."""
    print("| level | look-ahead [m] | outcome | missed | cross-track max [m] | jitter [rad/s] |")
    print("|---|---|---|---|---|---|")
    for level, rule in itertools.product((1, 2, 3), ("default", "e limits.v (delay + lag)")):
        overrides = {"parameters.level": level}
        data = load_mission(ROOT / "missions" / "disturbed.yaml", overrides).model_dump(mode="json")
        data = _with_rule(data, RULES[rule])
        look_ahead = data["controller"]["tracking"]["look_ahead"] or 0.05
        summary = run_mission(mission_from_dict(data)).summary()
        checks = summary["expectations"]
        missed = [c["metric"] for c in checks if not c["met"]]
        values = {c["metric"]: c["value"] for c in checks if c["phase"] == "circle"}
        print(
            f"| {level} | {look_ahead:.2f} | {summary['outcome']} | {len(missed)} "
            f"| {values['cross_track_error_max']:.3f} | {values['turn_rate_jitter']:.3f} |"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--generated", action="store_true", help="the generated set, delayed")
    parser.add_argument(
        "--shipped", action="store_true", help="missions/disturbed.yaml and controllers.yaml"
    )
    parser.add_argument("--runs", action="store_true", help="each run not a success too")
    args = parser.parse_args()
    if args.shipped:
        disturbed()
        controllers()
    elif args.generated:
        _table(list(generated_missions()), args.runs)
    else:
        _table(list(users_missions()), args.runs)


if __name__ == "__main__":
    main()
