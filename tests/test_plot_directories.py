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


def test_a_figure_plot_cannot_write_is_one_line_and_exit_2(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A full disk (or a directory made read-only) while plot draws: as `run`
    says it, the file and the reason, exit 2, not Python's errno text."""
    import errno
    import os

    from test_output_synthetic import circle_run

    from wmr_mission.commands import plot

    run_dir = circle_run().write(tmp_path / "circle", plots=False)

    def full(*args: object, **kwargs: object) -> list[Path]:
        raise OSError(errno.EFBIG, os.strerror(errno.EFBIG), str(run_dir / "verdicts.png"))

    monkeypatch.setattr(plot, "draw_all", full)
    assert plot.replot_command(run_dir) == 2
    err = capsys.readouterr().err
    assert (
        err == f"{run_dir / 'verdicts.png'}: cannot write: File too large; the data are unchanged\n"
    )
