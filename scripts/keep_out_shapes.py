"""The generated set's keep-out circles and ellipses made boxes and convex
polygons: the same missions with the other shapes a user keeps out
(docs/paper-notes.md, eq. (28), "The way round a box or polygon, decided
once").

    python scripts/keep_out_shapes.py OUT [SEED]
    WMR_MISSION_NO_JIT=1 python scripts/judge_generated.py --missions OUT/*.yaml

Each mission of tests/data/generated with a `stay_outside` circle or ellipse
is written twice to OUT: `NAME-box.yaml`, each such zone a box as long as
its diameter and 0.6 of it wide, turned by a drawn heading; and
`NAME-poly.yaml`, a convex pentagon with its corners drawn on the zone's
circle. The draws are seeded (SEED, 7 unless given): the same files every
time (53 missions, 106 files)."""

from __future__ import annotations

import math
import random
import sys
from pathlib import Path
from typing import Any

import yaml

GENERATED = Path(__file__).resolve().parents[1] / "tests" / "data" / "generated"


def _kept_out(mission: dict[str, Any]) -> list[str]:
    """The names of the circles and ellipses a phase keeps out of."""
    names = {
        constraint["stay_outside"]
        for phase in mission["phases"]
        for constraint in phase.get("constraints", [])
        if "stay_outside" in constraint
    }
    return sorted(n for n in names if mission["regions"][n]["type"] in ("circle", "ellipse"))


def _shape(region: dict[str, Any], shape: str, rng: random.Random) -> dict[str, Any]:
    """A box or a convex pentagon the size of a circle or an ellipse."""
    x, y = region["center"]
    radius = region.get("radius") or max(region["semi_axes"])
    if shape == "box":
        size = [round(2.0 * radius, 3), round(1.2 * radius, 3)]
        heading = round(rng.uniform(-3, 3), 3)
        return {"type": "box", "center": [x, y], "size": size, "heading": heading}
    angles = sorted(rng.uniform(0.0, 2.0 * math.pi) for _ in range(5))
    corners = [[x + radius * math.cos(a), y + radius * math.sin(a)] for a in angles]
    return {"type": "polygon", "vertices": [[round(u, 3), round(v, 3)] for u, v in corners]}


def main(argv: list[str]) -> int:
    if len(argv) not in (1, 2) or not (len(argv) == 1 or argv[1].isdigit()):
        print(__doc__, file=sys.stderr)
        return 2
    out = Path(argv[0])
    out.mkdir(parents=True, exist_ok=True)
    rng = random.Random(int(argv[1]) if len(argv) == 2 else 7)
    written = 0
    for path in sorted(GENERATED.glob("*.yaml")):
        names = _kept_out(yaml.safe_load(path.read_text()))
        if not names:
            continue
        for shape in ("box", "poly"):
            mission = yaml.safe_load(path.read_text())
            for name in names:
                mission["regions"][name] = _shape(mission["regions"][name], shape, rng)
            mission["name"] = f"{mission['name']}-{shape}"
            (out / f"{mission['name']}.yaml").write_text(yaml.safe_dump(mission, sort_keys=False))
            written += 1
    print(f"{written} missions written to {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
