"""README's list of commands names every command `wmr-mission --help` lists."""

from __future__ import annotations

import re
from pathlib import Path

from typer.testing import CliRunner

from wmr_mission.cli import app

README = Path(__file__).resolve().parent.parent / "README.md"


def test_readme_lists_every_command() -> None:
    text = README.read_text(encoding="utf-8")
    block = text.split("## Commands", 1)[1].split("```", 2)[1]
    listed = re.findall(r"^wmr-mission ([a-z-]+)", block, flags=re.MULTILINE)
    shown = CliRunner().invoke(app, ["--help"], env={"COLUMNS": "100"}).output
    commands = re.findall(r"^  ([a-z][a-z-]+)  ", shown.split("Commands:", 1)[1], re.MULTILINE)
    assert len(commands) >= 10
    assert sorted(set(commands) - set(listed)) == []
    assert listed.index("falsify") == listed.index("sweep") + 1  # as --help orders them


def test_view_help_names_each_directory_it_reports() -> None:
    shown = CliRunner().invoke(app, ["view", "-h"], env={"COLUMNS": "100"}).output
    assert "A run, campaign or falsification directory." in shown
