"""Compare the PNGs of two directory trees, decoded, pixel by pixel.

    python benchmarks/same_pixels.py BEFORE_DIR AFTER_DIR

Every ``*.png`` under BEFORE_DIR is compared with the file of the same relative
path under AFTER_DIR; for each that differs it prints how many pixels differ,
by how much at most, and where; and each PNG found in one tree only. Exit 1
when any differs or is missing. For
changes to the drawing code that should not change what the figures show:
write the same runs and campaigns before and after, then compare.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from PIL import Image


def _pixels(path: Path) -> np.ndarray:
    with Image.open(path) as image:
        return np.asarray(image.convert("RGB"), dtype=np.int16)


def main(before: Path, after: Path) -> int:
    compared, differing = 0, 0
    for old in sorted(before.rglob("*.png")):
        name = old.relative_to(before)
        new = after / name
        compared += 1
        if not new.exists():
            print(f"{name}: missing in {after}")
            differing += 1
            continue
        a, b = _pixels(old), _pixels(new)
        if a.shape != b.shape:
            print(
                f"{name}: {a.shape[1]}x{a.shape[0]} pixels before, {b.shape[1]}x{b.shape[0]} after"
            )
            differing += 1
            continue
        gap = np.abs(a - b).max(axis=2)
        if gap.any():
            rows, columns = np.nonzero(gap)
            print(
                f"{name}: {rows.size} pixels differ, by up to {gap.max()} of 255, "
                f"in columns {columns.min()}-{columns.max()}, rows {rows.min()}-{rows.max()}"
            )
            differing += 1
    for extra in sorted(after.rglob("*.png")):
        name = extra.relative_to(after)
        if not (before / name).exists():
            print(f"{name}: missing in {before}")
            differing += 1
    print(f"{compared} PNGs compared, {differing} differ")
    return 1 if differing else 0


if __name__ == "__main__":
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    sys.exit(main(Path(sys.argv[1]), Path(sys.argv[2])))
