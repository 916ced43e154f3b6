"""Every block of docs/controllers.md runs: the files it names are written,
its Python blocks and its commands run in order in one directory (on
PYTHONPATH); the head-to-head campaign runs small here, in full under
``-m sweep``, where its table must be the one in the page."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "controllers.md"
CAMPAIGN = "missions/campaigns/controllers.yaml"
BLOCK = re.compile(r"```(\w+)([^\n]*)\n(.*?)```", re.S)


def _blocks() -> list[tuple[str, str, str]]:
    """(language, file name or '', text) of each block, in order."""
    return [
        (language, info.strip().removeprefix("file=") if "file=" in info else "", text)
        for language, info, text in BLOCK.findall(DOC.read_text(encoding="utf-8"))
    ]


def _run_page(tmp_path: Path, runs: int | None) -> list[str]:
    """Run the page in ``tmp_path``; the output of each Python block."""
    (tmp_path / "missions").symlink_to(ROOT / "missions")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), str(ROOT / "tests")])}
    env.pop("WMR_MISSION_NO_JIT", None)
    outputs = []
    for language, name, text in _blocks():
        if name:
            (tmp_path / name).write_text(text, encoding="utf-8")
            if language == "yaml":
                assert isinstance(yaml.safe_load(text), dict), name
        elif language == "python":
            done = subprocess.run(
                [sys.executable, "-c", text], cwd=tmp_path, env=env, capture_output=True,
                text=True, timeout=900, check=False,
            )  # fmt: skip
            assert done.returncode == 0, (text, done.stderr[-3000:])
            outputs.append(done.stdout)
        elif language == "console":
            for line in text.splitlines():
                words = shlex.split(line.removeprefix("$ "))
                assert words[0] == "wmr-mission", line
                if words[1:3] == ["sweep", CAMPAIGN] and runs is not None:
                    words[2] = _small_campaign(tmp_path, runs)
                done = subprocess.run(
                    [sys.executable, "-m", "wmr_mission", *words[1:]], cwd=tmp_path, env=env,
                    capture_output=True, text=True, timeout=1800, check=False,
                )  # fmt: skip
                assert done.returncode == 0, (line, done.stdout[-2000:], done.stderr[-3000:])
        elif language == "yaml":  # a fragment of a mission: YAML at least
            assert isinstance(yaml.safe_load(text), dict)
        else:
            assert language == "text", language
    return outputs


def _small_campaign(tmp_path: Path, runs: int) -> str:
    campaign = yaml.safe_load((ROOT / CAMPAIGN).read_text(encoding="utf-8"))
    campaign["runs"] = runs
    campaign["mission"] = str(ROOT / "missions" / "controllers.yaml")
    path = tmp_path / "controllers-small.yaml"
    path.write_text(yaml.safe_dump(campaign, sort_keys=False), encoding="utf-8")
    return str(path)


def _table_in_page() -> str:
    text = DOC.read_text(encoding="utf-8")
    rows = [line for line in text.splitlines() if line.startswith("| paper |")
            or line.startswith("| pure-pursuit |") or line.startswith("| kanayama |")]  # fmt: skip
    return "\n".join(rows)


@pytest.mark.slow
def test_every_block_of_the_controllers_page_runs(tmp_path: Path) -> None:
    outputs = _run_page(tmp_path, runs=1)
    assert any(o.startswith("LQR: tracking RMS") for o in outputs), outputs
    assert any(o.startswith("filterpy EKF:") for o in outputs), outputs
    table = outputs[-1].splitlines()
    assert len(table) == 2 + 3 * 2 * 3  # header, rule, a row per cell
    assert _table_in_page().count("\n") == 3 * 2 * 3 - 1


@pytest.mark.sweep
def test_the_page_s_table_is_the_shipped_campaign_s(tmp_path: Path) -> None:
    outputs = _run_page(tmp_path, runs=None)
    rows = [line for line in outputs[-1].splitlines() if not line.startswith("| controller")]
    assert "\n".join(rows[1:]) == _table_in_page()
