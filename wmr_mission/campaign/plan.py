"""What each run of a campaign is: its drawn values and its sensor seed.

Run i depends only on (campaign seed, i): its generator is seeded by
``SeedSequence(seed).spawn(n)[i]``, built directly as
``SeedSequence(seed, spawn_key=(i,))`` (the same child, without making the
other n - 1). So any subset of runs, in any order, on any worker, gives the
same rows as a serial campaign.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from wmr_mission.campaign.models import Campaign

__all__ = ["Draw", "Plan"]


@dataclass(frozen=True)
class Draw:
    """One run: its index, its sensor seed and a value per varied path (campaign order)."""

    run: int
    seed: int
    values: dict[str, Any]


@dataclass(frozen=True)
class Plan:
    campaign: Campaign

    @property
    def paths(self) -> list[str]:
        return list(self.campaign.vary)

    def __len__(self) -> int:
        return self.campaign.total_runs()

    def draw(self, run: int) -> Draw:
        if not 0 <= run < len(self):
            raise IndexError(f"run {run} of a campaign of {len(self)} runs")
        c = self.campaign
        rng = np.random.default_rng(np.random.SeedSequence(c.seed, spawn_key=(run,)))
        seed = int(rng.integers(2**32, dtype=np.uint64))
        cell = run // c.runs  # grid cells in row-major order, the last grid axis fastest
        grid_index: dict[str, int] = {}
        for path, axis in reversed(c.vary.items()):
            if axis.grid is not None:
                cell, grid_index[path] = divmod(cell, len(axis.grid))
        values: dict[str, Any] = {}
        for path, axis in c.vary.items():
            if axis.grid is not None:
                values[path] = axis.grid[grid_index[path]]
            elif axis.uniform is not None:
                values[path] = float(rng.uniform(*axis.uniform))
            elif axis.normal is not None:
                values[path] = float(rng.normal(*axis.normal))
            elif axis.choice is not None:
                values[path] = axis.choice[int(rng.integers(len(axis.choice)))]
        return Draw(run, seed, values)
