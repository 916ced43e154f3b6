"""The package's structure (docs/architecture.md).

Layers and cycles are import-linter's contracts in pyproject.toml, run by
``lint-imports`` in .ci/run; here, what import-linter does not see: no module
reaches into a private name (``_name``) of another package.
"""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "wmr_mission"


def _package(module: str) -> str:
    """``wmr_mission.output.rundir`` -> ``wmr_mission.output``; a top-level module is its own."""
    return ".".join(module.split(".")[:2])


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def module_name(path: Path) -> str:
    return ".".join(path.relative_to(PACKAGE.parent).with_suffix("").parts).removesuffix(
        ".__init__"
    )


def private_reaches(source: str, module: str) -> list[str]:
    """``line: name`` for each private name of another package that the
    ``source`` of ``module`` uses."""
    own = _package(module)
    tree = ast.parse(source)
    modules: dict[str, str] = {}  # local name -> the module it is
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("wmr_mission"):
            source = str(node.module)
            for alias in node.names:
                if _private(alias.name) and _package(source) != own:
                    found.append(f"{node.lineno}: {source}.{alias.name}")
                modules[alias.asname or alias.name] = f"{source}.{alias.name}"
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("wmr_mission") and alias.asname:
                    modules[alias.asname] = alias.name
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name)
            and node.value.id in modules
            and _private(node.attr)
            and _package(modules[node.value.id]) != own
        ):
            found.append(f"{node.lineno}: {modules[node.value.id]}.{node.attr}")
    return found


def test_no_module_reaches_into_another_packages_private_names() -> None:
    reaches = {
        str(path.relative_to(PACKAGE.parent)): found
        for path in sorted(PACKAGE.rglob("*.py"))
        if (found := private_reaches(path.read_text(encoding="utf-8"), module_name(path)))
    }
    assert reaches == {}


def test_a_private_reach_is_seen() -> None:
    """The check itself: both ways of reaching a private name are found, a
    package's own private names are its own."""
    source = (
        "from wmr_mission.verdicts.metrics import _PointGrid\n"
        "from wmr_mission.kernels import jit\n"
        "from wmr_mission.campaign.rows import _private_of_my_own\n"
        "jit._state\n"
    )
    assert private_reaches(source, "wmr_mission.campaign.figures") == [
        "1: wmr_mission.verdicts.metrics._PointGrid",
        "4: wmr_mission.kernels.jit._state",
    ]


def test_the_architecture_names_every_module() -> None:
    """docs/architecture.md's table has a row for each module (a package's
    __init__ aside), by its path or, in a row of several, its file name."""
    table = (PACKAGE.parent / "docs" / "architecture.md").read_text(encoding="utf-8")
    missing = [
        str(path.relative_to(PACKAGE.parent))
        for path in sorted(PACKAGE.rglob("*.py"))
        if path.name != "__init__.py"
        and f"`{path.relative_to(PACKAGE.parent)}`" not in table
        and f"`{path.name}`" not in table
    ]
    assert missing == []
