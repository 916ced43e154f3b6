from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")
os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture(autouse=True)
def _close_figures() -> Iterator[None]:
    yield
    import matplotlib.pyplot as plt

    plt.close("all")


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20240611)


# A small campaign directory as `sweep` writes it, with figures and worst runs
# (one of which fails its expect): the data of the report and export tests.
LOOKING_CAMPAIGN = """version: 1
name: looking
mission: {mission}
runs: 4
seed: 11
vary:
  robot.initial_state.theta: {{uniform: [-3.0, 3.0]}}
  sensors.noise_std.x: {{choice: [0.0, 0.01]}}
  estimator.type: {{choice: [constrained-observer, ekf]}}
  controller.Q: {{grid: [[1, 1, 1], [1, 1, 10]]}}
"""


@pytest.fixture(scope="session")
def campaign_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from wmr_mission import run_campaign
    from wmr_mission.campaign import sweep

    root = tmp_path_factory.mktemp("looking")
    mission = Path(__file__).parent / "data" / "campaigns" / "short.yaml"
    path = root / "looking.yaml"
    path.write_text(LOOKING_CAMPAIGN.format(mission=mission), encoding="utf-8")
    out = root / "campaign"
    write_run = sweep.write_run

    def without_figures(*args: Any, **kwargs: Any) -> Any:
        return write_run(*args, **{**kwargs, "plots": False})

    # The campaign's figures, not the worst runs' (most of the time, and unused).
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(sweep, "write_run", without_figures)
        run_campaign(path, out=out, workers=1, plots=True)
    return out
