"""Robustness sweep of the tracking law: the paper's case studies from many starts.

Case 1 and case 2 (missions/case1.yaml, case2.yaml) are run from initial
headings every STEP degrees, with the estimate's heading either the true one
("known") or 0, optionally with sensor noise over several seeds and at other
sampling periods. Each run is judged against the acceptance of the tracking
law (docs/paper-notes.md, "The default tracking law"):

* noise-free: the turn rate at its limit on at most 1 % of the orbit after its
  first second; orbit RMS distance to the ellipse <= 1 mm after 2 s; final
  pose within 2 cm and 0.01 rad;
* noisy: orbit turn-rate jitter (RMS about its 25-sample mean) <= 0.5 rad/s;
  orbit RMS <= 1 cm; case 2's return outside the ellipse by at most 3 sigma.

    python scripts/tracking_sweep.py                       # noise-free, dt = 0.01
    python scripts/tracking_sweep.py --noise 0.01 --seeds 4
    python scripts/tracking_sweep.py --dt 0.02 --time-constant 0 --look-ahead 0.05

Prints one line per failing run and a summary; exit 1 when any run fails.
tests/test_tracking_sweep.py runs a small version by default and the whole
sweep under ``pytest -m sweep``.
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from geometry import distance_to_ellipse  # noqa: E402

from wmr_mission.output.result import RunResult  # noqa: E402
from wmr_mission.record import Outcome  # noqa: E402
from wmr_mission.sim.plan import plan_mission  # noqa: E402
from wmr_mission.sim.runner import run_mission  # noqa: E402
from wmr_mission.spec.loader import load_mission_text  # noqa: E402

ORBIT = 1  # phase index of the orbit in both case studies
SEMI_AXES = (5.5, 3.0)
JITTER_WINDOW = 25  # samples


@dataclass(frozen=True)
class Start:
    case: int
    heading: float  # true initial heading [rad]
    estimate_heading: float  # initial estimate's heading [rad]
    noise: float  # sensor noise std [m and rad]
    seed: int
    dt: float


@dataclass(frozen=True)
class Measured:
    outcome: str
    orbit_at_limit: float  # fraction of orbit samples after its first second
    orbit_rms: float  # [m] after the orbit's first 2 s
    jitter: float  # [rad/s] after the orbit's first second
    final_position: float  # [m]
    final_heading: float  # [rad]
    outside: float  # [m] largest distance outside the ellipse on case 2's return


def mission_text(start: Start) -> str:
    data = yaml.safe_load((ROOT / "missions" / f"case{start.case}.yaml").read_text())
    data["robot"]["dt"] = start.dt
    data["robot"]["initial_state"]["theta"] = start.heading
    data["estimator"]["initial_estimate"]["theta"] = start.estimate_heading
    data["sensors"]["noise_std"] = dict.fromkeys(("x", "y", "theta"), start.noise)
    data["sensors"]["seed"] = start.seed
    return yaml.safe_dump(data)


def turn_rate_jitter(omega: np.ndarray) -> float:
    """RMS of the turn rate about its centred 25-sample mean [rad/s]."""
    if omega.size <= JITTER_WINDOW:
        return math.inf
    mean = np.convolve(omega, np.ones(JITTER_WINDOW) / JITTER_WINDOW, mode="valid")
    centred = omega[JITTER_WINDOW // 2 : JITTER_WINDOW // 2 + mean.size]
    return float(np.sqrt(np.mean((centred - mean) ** 2)))


def measure(result: RunResult) -> Measured:
    orbit = result.phase == ORBIT
    t0 = result.t[orbit][0] if orbit.any() else math.inf
    after_1s = orbit & (result.t >= t0 + 1.0)
    after_2s = orbit & (result.t >= t0 + 2.0)
    omega = result.omega[after_1s]
    at_limit = float(np.mean(np.abs(omega) >= result.limits[1] * (1 - 1e-9))) if omega.size else 1
    jitter = turn_rate_jitter(omega)
    rms = math.inf
    if after_2s.any():
        d = distance_to_ellipse(result.x[after_2s], result.y[after_2s], *SEMI_AXES)
        rms = float(np.sqrt(np.mean(d**2)))
    outside = 0.0
    back = result.phase == 2
    if back.any() and result.phases[2].constraints:
        x, y = result.x[back][1:], result.y[back][1:]  # its first sample is the orbit's
        g = (x / SEMI_AXES[0]) ** 2 + (y / SEMI_AXES[1]) ** 2
        if (g > 1).any():
            outside = float(distance_to_ellipse(x[g > 1], y[g > 1], *SEMI_AXES).max())
    target = result.phases[-1].target or (0.0, 0.0, 0.0)
    return Measured(
        outcome=str(result.outcome),
        orbit_at_limit=at_limit,
        orbit_rms=rms,
        jitter=jitter,
        final_position=math.hypot(result.x[-1] - target[0], result.y[-1] - target[1]),
        final_heading=abs((result.theta[-1] - target[2] + math.pi) % (2 * math.pi) - math.pi),
        outside=outside,
    )


def run(start: Start, tracking: dict[str, Any]) -> Measured:
    """One run; ``tracking`` overrides the law after validation (``output``,
    ``look_ahead`` [m], ``time_constant`` [s]), so that laws ``validate``
    rejects, such as the former one-sample law, can still be measured."""
    plan = plan_mission(load_mission_text(mission_text(start), "sweep.yaml"))
    law = plan.controller_tuning
    look_ahead = 0.0 if tracking.get("output") == "axle" else law.look_ahead
    look_ahead = tracking.get("look_ahead", look_ahead)
    decay = law.error_decay
    if "time_constant" in tracking:
        tc = tracking["time_constant"]
        decay = math.exp(-start.dt / tc) if tc > 0 else 0.0
    if tracking.get("output") == "axle":
        decay = 0.0
    law = law._replace(look_ahead=look_ahead, error_decay=decay)
    return measure(run_mission(replace(plan, controller_tuning=law)))


def failures(start: Start, m: Measured) -> list[str]:
    """What the acceptance asks of one run and it missed."""
    missed = []
    if m.outcome != str(Outcome.success):
        missed.append(f"outcome {m.outcome}")
    if start.noise == 0.0:
        if m.orbit_at_limit > 0.01:
            missed.append(f"turn rate at its limit on {m.orbit_at_limit:.1%} of the orbit")
        if m.orbit_rms > 1e-3:
            missed.append(f"orbit RMS {m.orbit_rms:.2e} m")
        if m.final_position > 0.02 or m.final_heading > 0.01:
            missed.append(f"final {m.final_position:.3g} m, {m.final_heading:.3g} rad")
    else:
        if m.jitter > 0.5:
            missed.append(f"turn-rate jitter {m.jitter:.3g} rad/s")
        if m.orbit_rms > 0.01:
            missed.append(f"orbit RMS {m.orbit_rms:.2e} m")
        if m.outside > 3 * start.noise:
            missed.append(f"return {m.outside:.3g} m outside the ellipse")
    return missed


def starts(
    step_degrees: float, noise: float, seeds: int, dt: float, cases: tuple[int, ...] = (1, 2)
) -> list[Start]:
    headings = np.deg2rad(np.arange(-180.0, 180.0, step_degrees))
    return [
        Start(case, float(h), float(e), noise, seed, dt)
        for case in cases
        for h in headings
        for e in (float(h), 0.0)
        for seed in range(seeds)
    ]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--step", type=float, default=15.0, help="heading step [deg]")
    parser.add_argument("--noise", type=float, default=0.0, help="sensor noise std [m, rad]")
    parser.add_argument("--seeds", type=int, default=1)
    parser.add_argument("--dt", type=float, default=0.01)
    parser.add_argument("--cases", default="1,2")
    parser.add_argument("--look-ahead", type=float, default=None, help="[m]; default: the law's")
    parser.add_argument("--time-constant", type=float, default=None, help="[s]; default: the law's")
    parser.add_argument("--output", choices=("look-ahead", "axle"), default=None)
    args = parser.parse_args(argv)
    tracking: dict[str, Any] = {}
    if args.look_ahead is not None:
        tracking["look_ahead"] = args.look_ahead
    if args.time_constant is not None:
        tracking["time_constant"] = args.time_constant
    if args.output is not None:
        tracking["output"] = args.output
    cases = tuple(int(c) for c in args.cases.split(","))
    todo = starts(args.step, args.noise, args.seeds, args.dt, cases)
    failed = 0
    worst: dict[str, float] = {}
    for start in todo:
        m = run(start, tracking)
        for name in ("orbit_at_limit", "orbit_rms", "jitter", "final_position", "final_heading",
                     "outside"):  # fmt: skip
            worst[name] = max(worst.get(name, 0.0), getattr(m, name))
        missed = failures(start, m)
        if missed:
            failed += 1
            print(
                f"case {start.case} heading {math.degrees(start.heading):+6.1f} deg, estimate "
                f"{math.degrees(start.estimate_heading):+6.1f} deg, seed {start.seed}: "
                + "; ".join(missed)
            )
    print(f"{failed}/{len(todo)} runs fail; worst: " + ", ".join(
        f"{k} {v:.3g}" for k, v in worst.items()))  # fmt: skip
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
