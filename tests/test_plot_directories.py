"""`plot` given a campaign's or a falsification's directory says what it was
given and what reads it, in one line, rather than a manifest's missing key."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

FALSIFICATION_FILES = ("evaluations.csv", "falsify.json", "manifest.json")


@pytest.mark.parametrize(
    ("files", "kind"),
    [
        (FALSIFICATION_FILES, "a falsification directory"),
        (("runs.csv", "campaign.json", "manifest.json"), "a campaign directory"),
    ],
)
def test_plot_of_a_directory_of_many_runs_names_it(
    tmp_path: Path, files: tuple[str, ...], kind: str
) -> None:
    for name in files:  # what the command reads first: a manifest without 'run'
        (tmp_path / name).write_text("{}\n" if name.endswith(".json") else "run\n")
    before = sorted(path.name for path in tmp_path.iterdir())
    done = subprocess.run(
        [sys.executable, "-m", "wmr_mission", "plot", str(tmp_path)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 2  # a usage error, as view's and export's of a directory
    lines = done.stderr.strip().splitlines()
    assert lines == [
        f"{tmp_path}: {kind}, not a run directory: plot draws one run's figures; "
        f"wmr-mission view {tmp_path} reports it"
    ]
    assert sorted(path.name for path in tmp_path.iterdir()) == before  # nothing written
