"""Run the generated mission set and set the product's verdict beside the
independent judge's (scripts/soundness.py, docs/soundness.md).

    python scripts/judge_generated.py                       # all of tests/data/generated/
    python scripts/judge_generated.py --keep runs/judged    # keep the run directories
    python scripts/judge_generated.py --judge-only runs/judged   # judge kept runs again
    python scripts/judge_generated.py --missions tests/data/generated/gen-00*.yaml

Each mission runs as ``wmr-mission run --out DIR --no-plots`` would (through the
Python API, on all cores), and its run directory is judged from
``trajectory.csv`` and the mission file. Prints the confusion table

    product says success / failure  x  the run is sound / unsound

then every disagreement with its reasons: a *dishonest success* (the product
says success, the run is unsound) and a *false alarm* (the product says
failure, the run is sound). Exit 0 whatever the table holds; 2 on a usage error.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from collections.abc import Iterable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GENERATED = ROOT / "tests" / "data" / "generated"
sys.path.insert(0, str(Path(__file__).resolve().parent))

import soundness  # noqa: E402


@dataclass(frozen=True)
class Judged:
    mission: str  # file stem
    outcome: str  # the product's: success, timeout, expect-failed, ...
    message: str
    problems: tuple[str, ...]  # the judge's; empty when sound
    # summary.json's margin (null: -inf, or +inf without a check) and what sets it
    margin: float | None = None
    margin_check: str | None = None

    @property
    def success(self) -> bool:
        return self.outcome == "success"

    @property
    def margin_agrees(self) -> bool:
        """Whether the margin's sign is the verdict: >= 0 (or +inf, no check
        and no failure naming it) exactly for a success."""
        if self.margin is None:
            return self.success == (self.margin_check is None)
        return self.success == (self.margin >= 0.0)

    @property
    def sound(self) -> bool:
        return not self.problems


def run(mission: Path, run_dir: Path) -> None:
    """Simulate ``mission`` into ``run_dir`` as ``wmr-mission run --no-plots`` does."""
    from wmr_mission import load_mission, run_mission

    run_mission(load_mission(mission)).write(run_dir, plots=False)


def summary_of(run_dir: Path) -> dict[str, object]:
    import json

    summary: dict[str, object] = json.loads((run_dir / "summary.json").read_text())
    return summary


def run_and_judge(mission: Path, runs: Path, simulate: bool) -> Judged:
    run_dir = runs / mission.stem
    if simulate:
        run(mission, run_dir)
    summary = summary_of(run_dir)
    verdict = soundness.judge(mission, run_dir)
    margin, check = summary.get("margin"), summary.get("margin_check")
    return Judged(
        mission.stem,
        str(summary["outcome"]),
        str(summary["message"]),
        tuple(verdict.problems),
        None if margin is None else float(str(margin)),
        None if check is None else str(check),
    )


def judge_all(
    missions: Iterable[Path], runs: Path, simulate: bool = True, workers: int | None = None
) -> list[Judged]:
    missions = sorted(missions)
    with ProcessPoolExecutor(max_workers=workers or os.cpu_count()) as pool:
        futures = [pool.submit(run_and_judge, m, runs, simulate) for m in missions]
        return [f.result() for f in futures]


def table(judged: list[Judged]) -> str:
    """The confusion table, as Markdown."""

    def count(success: bool, sound: bool) -> int:
        return sum(j.success == success and j.sound == sound for j in judged)

    rows = [
        "| product says | sound | unsound | total |",
        "|---|---|---|---|",
    ]
    for success, label in ((True, "success"), (False, "failure")):
        sound, unsound = count(success, True), count(success, False)
        rows.append(f"| {label} | {sound} | {unsound} | {sound + unsound} |")
    total_sound = sum(j.sound for j in judged)
    rows.append(f"| total | {total_sound} | {len(judged) - total_sound} | {len(judged)} |")
    dishonest, alarms = count(True, False), count(False, True)
    rows.append("")
    rows.append(
        f"dishonest successes: {dishonest} of {len(judged)}; "
        f"false alarms: {alarms} of {len(judged)}"
    )
    return "\n".join(rows)


def by_acceleration(judged: list[Judged], missions: Iterable[Path]) -> str:
    """Successes with and without the robot's acceleration limits, and the
    failures with them named (the acceleration-limit work re-judges these)."""
    import yaml

    limited = {
        path.stem
        for path in missions
        if "acceleration"
        in ((yaml.safe_load(path.read_text()).get("robot") or {}).get("limits") or {})
    }
    lines = []
    for label, group in (("without", False), ("with", True)):
        runs = [j for j in judged if (j.mission in limited) == group]
        wins = sum(j.success for j in runs)
        lines.append(f"{label} acceleration limits: {wins} of {len(runs)} succeed")
    failed = [j.mission for j in judged if j.mission in limited and not j.success]
    lines.append("failed with acceleration limits: " + (", ".join(failed) or "none"))
    return "\n".join(lines)


def disagreements(judged: list[Judged]) -> str:
    lines = []
    for j in judged:
        if j.success and not j.sound:
            lines.append(f"dishonest success  {j.mission}")
            lines += [f"    {problem}" for problem in j.problems]
    for j in judged:
        if not j.success and j.sound:
            lines.append(f"false alarm        {j.mission}: {j.outcome}: {j.message}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--missions", type=Path, nargs="+", default=None)
    parser.add_argument("--keep", type=Path, default=None, help="write the runs here")
    parser.add_argument("--judge-only", type=Path, default=None, help="judge the runs kept here")
    parser.add_argument("--workers", type=int, default=None)
    parser.add_argument(
        "--agreements", action="store_true", help="also list the unsound runs both call failures"
    )
    args = parser.parse_args(argv)
    missions = args.missions or sorted(GENERATED.glob("*.yaml"))
    if args.judge_only is not None:
        judged = judge_all(missions, args.judge_only, simulate=False, workers=args.workers)
    elif args.keep is not None:
        args.keep.mkdir(parents=True, exist_ok=True)
        judged = judge_all(missions, args.keep, workers=args.workers)
    else:
        with tempfile.TemporaryDirectory() as scratch:
            judged = judge_all(missions, Path(scratch), workers=args.workers)
    print(table(judged))
    print()
    print(by_acceleration(judged, missions))
    print()
    print(disagreements(judged))
    if args.agreements:
        for j in judged:
            if not j.success and not j.sound:
                print(f"both fail          {j.mission}: {j.outcome}")
                print("    " + "\n    ".join(j.problems))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
