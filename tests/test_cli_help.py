from typer.testing import CliRunner

from wmr_mission.cli import app


def test_help_lists_every_command() -> None:
    result = CliRunner().invoke(app, ["--help"])
    assert result.exit_code == 0
    for command in ("run", "validate", "schema", "plot", "bench"):
        assert command in result.output
