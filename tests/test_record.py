"""No command writes over a run's, a campaign's or a falsification's record
(wmr_mission/review/record.py):
every path the user names for an output is checked, symbolic links followed."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest
from test_output_synthetic import circle_run
from typer.testing import CliRunner

from wmr_mission.cli import app

MISSION = Path(__file__).parent / "data" / "campaigns" / "short.yaml"
CAMPAIGN = Path(__file__).parents[1] / "missions" / "campaigns" / "case1-dt.yaml"


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return circle_run().write(tmp_path_factory.mktemp("record") / "circle", plots=False)


def _fingerprint(directory: Path) -> dict[str, str]:
    return {
        str(path.relative_to(directory)): hashlib.sha256(path.read_bytes()).hexdigest()
        for path in sorted(directory.rglob("*"))
        if path.is_file()
    }


def _refused(arguments: list[str], directory: Path, written: str) -> None:
    before = _fingerprint(directory)
    result = CliRunner().invoke(app, arguments)
    assert result.exit_code == 2, result.output
    assert result.stdout == ""
    assert result.stderr.count("\n") == 1, result.stderr
    assert f"is {written} of the " in result.stderr
    assert "choose another --out" in result.stderr
    assert _fingerprint(directory) == before


def _links(tmp_path: Path, directory: Path, name: str) -> tuple[Path, Path]:
    """A link to the file ``name`` of ``directory``, and a path through a link to it."""
    to_file = tmp_path / f"link-to-{name}.html"
    to_file.symlink_to(directory / name)
    to_directory = tmp_path / f"link-to-{directory.name}-for-{name}"
    to_directory.symlink_to(directory)
    return to_file, to_directory / name


@pytest.mark.parametrize("command", ["view", "export"])
def test_no_output_is_written_over_a_run_s_record(
    command: str, run_dir: Path, tmp_path: Path
) -> None:
    extra = ["--format", "parquet"] if command == "export" else []
    for name in ("trajectory.csv", "summary.json", "transitions.json", "manifest.json", "xy.png"):
        _refused([command, str(run_dir), "--out", str(run_dir / name), *extra], run_dir, name)
        linked_file, through_directory = _links(tmp_path, run_dir, name)
        for out in (linked_file, through_directory):
            _refused([command, str(run_dir), "--out", str(out), *extra], run_dir, name)
    # another run's record as well as this one's
    other = circle_run().write(tmp_path / "other", plots=False)
    _refused(
        [command, str(run_dir), "--out", str(other / "summary.json"), *extra], other, "summary.json"
    )


@pytest.mark.parametrize("command", ["view", "export"])
def test_no_output_is_written_over_a_campaign_s_record(
    command: str, campaign_dir: Path, tmp_path: Path
) -> None:
    extra = ["--format", "parquet"] if command == "export" else []
    worst = next((campaign_dir / "worst").iterdir())
    for directory, name in (
        (campaign_dir, "runs.csv"),
        (campaign_dir, "campaign.json"),
        (campaign_dir, "manifest.json"),
        (worst, "trajectory.csv"),
    ):
        arguments = [command, str(campaign_dir), *extra, "--out"]
        _refused([*arguments, str(directory / name)], campaign_dir, name)
        linked_file, through_directory = _links(tmp_path, directory, name)
        _refused([*arguments, str(linked_file)], campaign_dir, name)
        _refused([*arguments, str(through_directory)], campaign_dir, name)


def test_other_files_in_a_run_directory_are_written(run_dir: Path, tmp_path: Path) -> None:
    for arguments in (
        ["view", str(run_dir)],
        ["view", str(run_dir), "--out", str(run_dir / "notes.html")],
        ["export", str(run_dir), "--format", "parquet"],
        ["export", str(run_dir), "--format", "parquet", "--out", str(run_dir / "t.parquet")],
    ):
        result = CliRunner().invoke(app, arguments)
        assert result.exit_code == 0, result.output
    link = tmp_path / "report-link.html"
    link.symlink_to(tmp_path / "elsewhere.html")
    result = CliRunner().invoke(app, ["view", str(run_dir), "--out", str(link)])
    assert result.exit_code == 0, result.output


def test_run_and_sweep_never_take_a_record_s_directory(
    run_dir: Path, campaign_dir: Path, tmp_path: Path
) -> None:
    """Their --out names a directory, taken only new or empty, and never inside
    a run's record (a worst run's of a campaign among them)."""
    worst = next((campaign_dir / "worst").iterdir())
    for arguments, directory in (
        (["run", str(MISSION), "--out", str(run_dir)], run_dir),
        (["run", str(MISSION), "--out", str(run_dir / "summary.json")], run_dir),
        (["sweep", str(CAMPAIGN), "--out", str(campaign_dir)], campaign_dir),
        (["sweep", str(CAMPAIGN), "--out", str(campaign_dir / "runs.csv")], campaign_dir),
        # nor a new directory inside a record, nor one named as its claim
        (["run", str(MISSION), "--out", str(run_dir / "sub")], run_dir),
        (["run", str(MISSION), "--out", str(run_dir / ".wmr-mission-run")], run_dir),
        (["run", str(MISSION), "--out", str(worst / "new")], campaign_dir),
        (["sweep", str(CAMPAIGN), "--out", str(run_dir / "sub")], run_dir),
    ):
        before = _fingerprint(directory)
        result = CliRunner().invoke(app, arguments)
        assert result.exit_code == 2, result.output
        assert _fingerprint(directory) == before
    assert not (run_dir / "sub").exists()
    assert not (worst / "new").exists()


@pytest.fixture(scope="module")
def falsify_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from wmr_mission.api import falsify_campaign

    out = tmp_path_factory.mktemp("record") / "falsify"
    park = Path(__file__).parent / "data" / "falsify" / "park-campaign.yaml"
    falsify_campaign(park, budget=8, seed=1, out=out, plots=False)
    return out


@pytest.mark.parametrize("command", ["view", "export"])
def test_no_output_is_written_over_a_falsification_s_record(
    command: str, falsify_dir: Path, run_dir: Path
) -> None:
    """Its evaluations, its record, its manifest and the failing missions it
    wrote (written over with a run's report or table, they were lost)."""
    extra = ["--format", "parquet"] if command == "export" else []
    failing = sorted((falsify_dir / "failing").glob("*.yaml"))
    assert failing  # the park campaign fails within its 8 runs
    names = ["evaluations.csv", "falsify.json", "manifest.json"]
    for out in [*(falsify_dir / name for name in names), failing[0]]:
        _refused([command, str(run_dir), *extra, "--out", str(out)], falsify_dir, out.name)


def test_a_report_never_lands_in_another_record_s_directory(
    run_dir: Path, campaign_dir: Path, tmp_path: Path
) -> None:
    """A run's report written into another run's (or a campaign's) directory
    passes for that record's own, under its default name or any other."""
    other = circle_run().write(tmp_path / "other", plots=False)
    for directory, source in ((other, run_dir), (campaign_dir, run_dir), (run_dir, campaign_dir)):
        for name in ("report.html", "newname.html", "notes.txt"):
            before = _fingerprint(directory)
            target = directory / name
            result = CliRunner().invoke(app, ["view", str(source), "--out", str(target)])
            assert result.exit_code == 2, result.output
            assert f"which keeps its own outputs, not {source}'s" in result.stderr
            assert result.stderr.count("\n") == 1, result.stderr
            assert _fingerprint(directory) == before
    result = CliRunner().invoke(
        app, ["export", str(run_dir), "--format", "parquet", "--out", str(other / "t.parquet")]
    )
    assert result.exit_code == 2, result.output
    # its own directory's report, and another name there, are written
    for target in (other / "report.html", other / "of-the-circle.html"):
        result = CliRunner().invoke(app, ["view", str(other), "--out", str(target)])
        assert result.exit_code == 0, result.output


@pytest.mark.parametrize("command", ["view", "export"])
def test_a_file_of_the_user_s_is_never_written_over(
    command: str, run_dir: Path, tmp_path: Path
) -> None:
    """Outside any record, --out replaces an earlier output of the command's
    own kind only: a mission, a table or another kind's output named by
    mistake is kept, with one line and exit 2 (a mission written over with a
    report was lost)."""
    extra = ["--format", "parquet"] if command == "export" else []
    own, other = (".parquet", ".html") if command == "export" else (".html", ".parquet")
    for name in ("mission.yaml", "data.csv", "script.py", f"earlier{other}", "no-suffix"):
        target = tmp_path / name
        target.write_text("version: 1\n")
        result = CliRunner().invoke(app, [command, str(run_dir), "--out", str(target), *extra])
        assert result.exit_code == 2, result.output
        assert result.stderr.count("\n") == 1, result.stderr
        assert f"is a file already, not an earlier {own} output" in result.stderr
        assert target.read_text() == "version: 1\n"
    # a new file of any name is written; one of the kind's suffix, written over again
    for name, times in ((f"earlier{own}", 2), (f"EARLIER{own.upper()}", 2), ("new-file.txt", 1)):
        target = tmp_path / name
        for _ in range(times):
            result = CliRunner().invoke(app, [command, str(run_dir), "--out", str(target), *extra])
            assert result.exit_code == 0, result.output
    if command == "view":  # a page of the user's own is no earlier report
        notes = tmp_path / "notes.html"
        notes.write_text("<html><body>my notes</body></html>\n")
        result = CliRunner().invoke(app, ["view", str(run_dir), "--out", str(notes)])
        assert result.exit_code == 2, result.output
        assert "is a file already, not an earlier .html output" in result.stderr
        assert notes.read_text() == "<html><body>my notes</body></html>\n"


def test_a_pipe_is_never_replaced_and_a_link_is_written_through(
    run_dir: Path, tmp_path: Path
) -> None:
    """`view --out` and `export --out` at a named pipe (as at /dev/null, a
    device): refused, the pipe left a pipe. At a symbolic link to an earlier
    report: the report it points to is written, the link kept."""
    import os
    import stat

    pipe = tmp_path / "pipe.html"
    os.mkfifo(pipe)
    for arguments in (
        ["view", str(run_dir), "--out", str(pipe)],
        ["export", str(run_dir), "--format", "parquet", "--out", str(pipe)],
    ):
        result = CliRunner().invoke(app, arguments)
        assert result.exit_code == 2, result.output
        assert "is not a file (a device, a pipe or a socket)" in result.stderr
        assert stat.S_ISFIFO(pipe.lstat().st_mode)
    report = tmp_path / "reports" / "earlier.html"
    report.parent.mkdir()
    report.write_text('<main id="report"></main>')
    link = tmp_path / "latest.html"
    link.symlink_to(report)
    result = CliRunner().invoke(app, ["view", str(run_dir), "--out", str(link)])
    assert result.exit_code == 0, result.output
    assert link.is_symlink()
    assert link.resolve() == report.resolve()
    assert len(report.read_bytes()) > 1000  # the new report, where the link points
    # a loop of links: refused, the links kept
    loop_a, loop_b = tmp_path / "loop-a.html", tmp_path / "loop-b.html"
    loop_a.symlink_to(loop_b)
    loop_b.symlink_to(loop_a)
    result = CliRunner().invoke(app, ["view", str(run_dir), "--out", str(loop_a)])
    assert result.exit_code == 2, result.output
    assert "is a loop of symbolic links" in result.stderr
    assert loop_a.is_symlink()
    assert loop_b.is_symlink()


def test_an_out_below_a_file_is_said_to_be_below_no_directory(tmp_path: Path) -> None:
    """`--out afile/sub`: the file is named as no directory, not "File exists"."""
    afile = tmp_path / "afile"
    afile.write_text("mine\n", encoding="utf-8")
    park = Path(__file__).parent / "data" / "falsify" / "park-campaign.yaml"
    for arguments in (
        ["run", str(MISSION), "--no-plots"],
        ["sweep", str(CAMPAIGN), "--no-plots"],
        ["falsify", str(park), "--budget", "2", "--no-plots"],
    ):
        for out in (afile / "sub", afile / "new" / "sub"):
            result = CliRunner().invoke(app, [*arguments, "--out", str(out)])
            assert result.exit_code == 2, result.output
            assert f"{afile} is not a directory; choose another --out" in result.output
            assert "File exists" not in result.output
    assert afile.read_text(encoding="utf-8") == "mine\n"
