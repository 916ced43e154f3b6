from __future__ import annotations

import os
from collections.abc import Iterator

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")
os.environ.setdefault("MPLBACKEND", "Agg")
# `run` compiles in the foreground, as before the background compile: no
# process outlives a test (wmr_mission.commands.background_compile).
os.environ["WMR_MISSION_FOREGROUND_COMPILE"] = "1"


@pytest.fixture(autouse=True)
def _close_figures() -> Iterator[None]:
    yield
    import matplotlib.pyplot as plt

    plt.close("all")


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20240611)
