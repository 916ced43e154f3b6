"""The generated set's robots given bodies: the same missions driven by a round
robot and by a rectangular one, as users' robots are (docs/mission-format.md,
"The robot's body and boxes"; docs/soundness.md, "Robots with bodies").

    python scripts/robot_bodies.py OUT
    WMR_MISSION_NO_JIT=1 python scripts/judge_generated.py --missions OUT/*.yaml

Each mission of tests/data/generated with a zone (a phase's constraint or the
geofence) is written twice to OUT: `NAME-disc.yaml`, a `robot.footprint` of
radius R, and `NAME-rect.yaml`, a rectangle 1.6 R long and R wide whose
front reaches 1.0 R ahead of the axle and whose back 0.6 R behind it. R is
drawn from 0.1-0.3 m, then halved (twice at most) while `validate` finds the
mission unsound for it (a start, a target or a path the body cannot keep
clear); a mission still unsound at a quarter of its draw is left out and
counted. The draws are seeded: the same files every time."""

from __future__ import annotations

import random
import sys
import tempfile
from pathlib import Path
from typing import Any

import yaml

GENERATED = Path(__file__).resolve().parents[1] / "tests" / "data" / "generated"


def _has_zones(mission: dict[str, Any]) -> bool:
    return bool(mission.get("geofence")) or any(
        phase.get("constraints") for phase in mission["phases"]
    )


def _footprint(shape: str, radius: float) -> dict[str, Any]:
    if shape == "disc":
        return {"radius": round(radius, 3)}
    front, back, half = 1.0 * radius, -0.6 * radius, 0.5 * radius
    corners = [[front, -half], [front, half], [back, half], [back, -half]]
    return {"polygon": [[round(u, 3), round(v, 3)] for u, v in corners]}


def _sound(text: str) -> bool:
    """Whether ``validate`` finds no error in the mission ``text``."""
    from wmr_mission.campaign.load import check_file

    with tempfile.NamedTemporaryFile("w", suffix=".yaml", delete=False) as handle:
        handle.write(text)
    try:
        return not any(d.severity == "error" for d in check_file(Path(handle.name)))
    finally:
        Path(handle.name).unlink()


def main(argv: list[str]) -> int:
    if len(argv) != 1:
        print(__doc__, file=sys.stderr)
        return 2
    out = Path(argv[0])
    out.mkdir(parents=True, exist_ok=True)
    rng = random.Random(11)
    written, left_out = 0, []
    for path in sorted(GENERATED.glob("*.yaml")):
        if not _has_zones(yaml.safe_load(path.read_text())):
            continue
        for shape in ("disc", "rect"):
            drawn = rng.uniform(0.1, 0.3)
            for radius in (drawn, drawn / 2.0, drawn / 4.0):
                mission = yaml.safe_load(path.read_text())
                mission["robot"]["footprint"] = _footprint(shape, radius)
                mission["name"] = f"{mission['name']}-{shape}"
                text = yaml.safe_dump(mission, sort_keys=False)
                if _sound(text):
                    (out / f"{mission['name']}.yaml").write_text(text)
                    written += 1
                    break
            else:
                left_out.append(f"{path.stem}-{shape}")
    print(f"{written} missions written to {out}; {len(left_out)} left out: {', '.join(left_out)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
