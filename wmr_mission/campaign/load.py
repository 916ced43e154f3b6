"""Read a campaign file into a :class:`Campaign`, with a position for every problem.

The text is read exactly as a mission file is (plain YAML only, positions
kept); then each varied path is checked against the mission: the mission must
validate with the axis at each of its extremes (every value of a choice or
grid), so a value that breaks the mission is reported before anything runs.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shlex
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Final

from pydantic import ValidationError

from wmr_mission.spec.checks import DataPath, Finding, check_across_fields, read_by_sampling_checks
from wmr_mission.spec.loader import (
    Diagnostic,
    Document,
    MissionError,
    Override,
    apply_override,
    check_mission_bytes,
    check_mission_document,
    check_mission_text,
    decode_source,
    diagnostic,
    dotted_path,
    internal_error,
    parse_path,
    read_document,
    read_source,
    resolved_path,
    translate,
    validation_context,
    written_path,
)
from wmr_mission.spec.models import Mission
from wmr_mission.terminal import shown

if TYPE_CHECKING:  # imported where a campaign is checked: `validate` of a mission loads none
    from wmr_mission.campaign.models import Axis, Campaign

__all__ = [
    "LoadedCampaign",
    "check_campaign",
    "check_file",
    "is_campaign_text",
    "load_campaign",
    "replay_line",
    "value_text",
]

# Drawn per run by the campaign itself: varying it would break the replay of a run.
_SEED_PATH: Final = ("sensors", "seed")


class LoadedCampaign:
    """A checked campaign and the mission it varies, each file read once: the
    hashes are of the bytes checked and run, whatever happens to the files since."""

    def __init__(
        self,
        campaign: Campaign,
        path: Path,
        mission_path: Path,
        mission_text: str,
        *,
        campaign_sha256: str,
        mission_sha256: str,
        settings: Sequence[Override] = (),
        positions: Mapping[DataPath, tuple[int, int]] | None = None,
    ):
        self.campaign = campaign
        self.path = path
        # where the campaign file wrote its keys (line, column): what a message
        # about them points at, as a mission's errors do
        self.positions = dict(positions or {})
        self.mission_path = mission_path
        self.mission_text = mission_text
        self.campaign_sha256 = campaign_sha256
        self.mission_sha256 = mission_sha256
        # Read once here, not per run: reading the YAML costs more than checking it.
        document, findings = read_document(mission_text)
        if document is None or findings:
            raise ValueError(f"{mission_path}: not a checked mission")
        # `sweep --set`: set once in the mission every run starts from, and
        # named in each run's messages and replay command as the user wrote it.
        self.settings = tuple(settings)
        for setting in self.settings:
            if apply_override(document, setting) is not None:
                raise ValueError(f"{setting.source}: not a checked setting")
        self.mission_document = document

    def setting_texts(self) -> list[str]:
        """Each of :attr:`settings` as ``PATH=VALUE``, as ``--set`` takes it back."""
        return [f"{dotted_path(s.path)}={value_text(s.value)}" for s in self.settings]

    def mission_with(
        self, overrides: Sequence[Override]
    ) -> tuple[Mission | None, list[Diagnostic]]:
        """The mission with ``overrides`` set, checked exactly as ``run --set`` checks it."""
        return check_mission_document(self.mission_document, str(self.mission_path), overrides)

    def mission_across_fields(self, overrides: Sequence[Override]) -> Mission | None:
        """The mission with ``overrides`` set when its fields and the checks across
        them (``check_across_fields``) accept it, else None (:meth:`mission_with`
        then says why). The checks that sample paths and regions are left out:
        `validate` ran them with each axis at its extremes."""
        # Overrides write inside the top-level sections they name: only those are copied.
        written = {str(override.path[0]) for override in overrides}
        data = self.mission_document.data
        document = Document(
            data={key: _copy(value) if key in written else value for key, value in data.items()}
        )
        if any(apply_override(document, override) is not None for override in overrides):
            return None
        try:
            mission = Mission.model_validate(
                document.data, context=validation_context(document.data)
            )
        except ValidationError:
            return None
        if any(f.severity == "error" for f in check_across_fields(mission)):
            return None
        return mission


def _copy(data: Any) -> Any:
    """A copy of plain data (mappings, lists, scalars), as ``copy.deepcopy`` makes
    it at a fifth of the cost."""
    if isinstance(data, dict):
        return {key: _copy(item) for key, item in data.items()}
    if isinstance(data, list):
        return [_copy(item) for item in data]
    return data


def value_text(value: Any) -> str:
    """A drawn value as YAML text that reads back to exactly the same value.

    JSON is YAML 1.2, and Python writes the shortest text of a float that
    reads back to the same float.
    """
    return json.dumps(value)


def replay_line(
    mission_file: str,
    settings: Sequence[str],
    values: Mapping[str, Any],
    seed: int | str,
    fingerprint: str,
    mission_sha256: str | None = None,
) -> str:
    """The one-line ``wmr-mission run`` command of a campaign's run: the
    campaign's settings (``PATH=VALUE``) first, then the run's drawn values;
    ``mission_sha256``: the mission file's as the campaign read it, whose first
    MISSION_DIGITS ``run`` compares (``--expect-mission``)."""
    words = ["wmr-mission", "run", mission_file]
    for setting in settings:
        words += ["--set", setting]
    for path, value in values.items():
        words += ["--set", f"{path}={value_text(value)}"]
    words += ["--seed", str(seed)]
    if mission_sha256 is not None:
        words += ["--expect-mission", mission_sha256[:MISSION_DIGITS]]
    words += ["--expect-environment", fingerprint]
    return shlex.join(words)


def recorded_sha256(manifest: Mapping[str, Any]) -> str | None:
    """The mission file's sha256 a campaign's or a search's manifest records
    (None in a record without it), for :func:`replay_line`."""
    found = manifest.get("mission_sha256")
    return found if isinstance(found, str) else None


# The hexadecimal digits of a mission file's sha256 a replay line carries.
MISSION_DIGITS: Final = 16


def override(path: str, value: Any) -> Override:
    """The ``--set PATH=VALUE`` of one drawn value, the mission's one override mechanism."""
    text = f"{path}={value_text(value)}"
    return Override(parse_path(path), value, f"--set {text}")


# Top-level keys of a campaign that a mission never has.
_CAMPAIGN_KEYS: Final = ("mission", "runs", "vary")
# One of them at the start of a line: how a campaign too large to read is told
# from a mission (reading YAML costs about 5 s a megabyte).
_CAMPAIGN_KEY_LINE: Final = re.compile(r"^(?:mission|runs|vary)[ \t]*:", re.MULTILINE)

MAX_CAMPAIGN_BYTES: Final = 100_000
"""Largest accepted campaign file (a mission may be ten times larger): room for
an axis of 10 000 values, which `validate` checks in 0.23 s when they repeat
one value and 1.4 s when all differ (`python benchmarks/measure.py checks`).
A larger one is refused before it is read, which alone would take seconds."""


def is_campaign_text(text: str) -> bool:
    """Whether a file is a campaign: a mapping with a top-level ``mission``,
    ``runs`` or ``vary`` key."""
    if len(text) > MAX_CAMPAIGN_BYTES:
        return _CAMPAIGN_KEY_LINE.search(text) is not None
    return _campaign_document(read_document(text)) is not None


def _campaign_document(read: tuple[Document | None, list[Finding]]) -> Document | None:
    data = read[0].data if read[0] is not None else None
    if isinstance(data, dict) and any(key in data for key in _CAMPAIGN_KEYS):
        return read[0]
    return None


def check_file(path: Path) -> list[Diagnostic]:
    """Every problem of a mission or campaign file."""
    raw, diagnostics = read_source(path)
    if raw is None:
        return diagnostics
    text, diagnostics = decode_source(raw, str(path))
    if text is None:
        return diagnostics
    if len(raw) > MAX_CAMPAIGN_BYTES:
        if is_campaign_text(text):
            return _check(path, raw, text)[1]
        return check_mission_text(text, str(path))[1]
    read = read_document(text)  # once: a file of many values takes a while to read
    if _campaign_document(read) is not None:
        return _check(path, raw, text, read)[1]
    return check_mission_text(text, str(path), read=read)[1]


def check_campaign(
    path: str | Path, settings: Sequence[Override] = ()
) -> tuple[LoadedCampaign | None, list[Diagnostic]]:
    """Every problem of a campaign file, and the campaign if it has no error.

    ``settings``: fields set in the campaign's mission for every run, as
    ``sweep --set`` sets them; each is checked as ``run --set`` checks it."""
    path = Path(path)
    raw, diagnostics = read_source(path)
    if raw is None:
        return None, diagnostics
    text, diagnostics = decode_source(raw, str(path))
    if text is None:
        return None, diagnostics
    return _check(path, raw, text, settings=settings)


def load_campaign(path: str | Path, settings: Sequence[Override] = ()) -> LoadedCampaign:
    """The campaign of a file; raises :class:`MissionError` with every error."""
    loaded, diagnostics = check_campaign(path, settings)
    if loaded is None:
        raise MissionError([d for d in diagnostics if d.severity == "error"])
    return loaded


def _check(
    path: Path,
    raw: bytes,
    text: str,
    read: tuple[Document | None, list[Finding]] | None = None,
    settings: Sequence[Override] = (),
) -> tuple[LoadedCampaign | None, list[Diagnostic]]:
    filename = str(path)
    if len(raw) > MAX_CAMPAIGN_BYTES:
        message = (
            f"campaign file too large: more than {MAX_CAMPAIGN_BYTES} bytes; a campaign names "
            "its mission and the values of a few fields (draw many values with uniform or "
            "normal, or split the campaign)"
        )
        return None, [Diagnostic(filename, 1, 1, message)]
    from wmr_mission.campaign.models import Campaign

    try:
        document, findings = read if read is not None else read_document(text)
        if document is None:
            return None, [diagnostic(filename, None, f) for f in findings]
        campaign: Campaign | None = None
        if not isinstance(document.data, dict):
            findings.append(
                Finding((), "a campaign is a mapping of keys (version, name, mission, runs, vary)")
            )
        else:
            try:
                campaign = Campaign.model_validate(document.data)
            except ValidationError as error:
                for item in error.errors(include_url=False):
                    if item["type"] == "none_required":  # an optional key: absent is its None
                        continue
                    if not _under(written_path(item["loc"], document.data), document.refused):
                        finding = translate(item, document, Campaign)
                        unit = _unit_of_bound(item, finding, document.data, path)
                        findings.append(_of_campaign(unit or finding))
        diagnostics = [diagnostic(filename, document, f) for f in findings]
        if campaign is None or diagnostics:
            return None, _sorted(diagnostics)
        campaign_sha256 = hashlib.sha256(raw).hexdigest()
        loaded, more = _check_against_mission(
            path, campaign, document.keys, campaign_sha256, settings
        )
        return loaded, _sorted(more)
    except Exception as error:  # last resort: bad input must never show a traceback
        return None, [internal_error(filename, error)]


_UNIT_SAID: Final = ": units are not written: "


def _unit_of_bound(item: Any, finding: Finding, data: Any, path: Path) -> Finding | None:
    """A uniform or normal bound written with a unit (`-30 deg`), said in the
    varied field's unit as the mission says it and as a choice's value is said
    (`theta is in rad; write -0.523599 for -30 deg`), where the campaign's own
    schema knows only that a number is expected; None to keep ``finding``."""
    at = finding.path
    mission = data.get("mission") if isinstance(data, dict) else None
    if _UNIT_SAID not in finding.message or len(at) != 4 or not isinstance(mission, str):
        return None
    if at[0] != "vary" or at[2] not in ("uniform", "normal") or not isinstance(at[1], str):
        return None
    mission_path = path.parent / mission
    # a regular file only (a pipe read here would be read empty by the run);
    # anything else keeps the campaign's own message, the mission's fault said later
    raw = read_source(mission_path)[0] if mission_path.is_file() else None
    document = None if raw is None else read_document(raw.decode("utf-8", "replace"))[0]
    try:
        field = parse_path(at[1])
    except ValueError:
        return None
    if document is None:
        return None
    said = translate({**item, "loc": field}, document, Mission).message
    if _UNIT_SAID not in said or said.endswith(": write the number alone"):
        return None
    return finding._replace(message=dotted_path(at) + _UNIT_SAID + said.split(_UNIT_SAID, 1)[1])


def _of_campaign(finding: Finding) -> Finding:
    """The translation names the top level "the mission"; here it is the campaign."""
    message = finding.message.replace("in the mission", "in the campaign")
    return finding._replace(message=message)


def _under(path: tuple[str | int, ...], refused: set[tuple[str | int, ...]]) -> bool:
    return any(path[: len(r)] == r for r in refused)


def _sorted(diagnostics: Sequence[Diagnostic]) -> list[Diagnostic]:
    return sorted(set(diagnostics), key=lambda d: (d.file, d.line, d.column, d.message))


def _check_against_mission(
    path: Path,
    campaign: Campaign,
    keys: dict[tuple[str | int, ...], tuple[int, int]],
    campaign_sha256: str,
    settings: Sequence[Override],
) -> tuple[LoadedCampaign | None, list[Diagnostic]]:
    from wmr_mission.campaign.models import MAX_RUNS

    filename = str(path)

    def at(data_path: tuple[str | int, ...], message: str) -> Diagnostic:
        # a check across the campaign and its mission, once each field is sound
        line, column = keys.get(data_path, (1, 1))
        return Diagnostic(filename, line, column, message, stage="semantics")

    if campaign.total_runs() > MAX_RUNS:
        return None, [
            at(
                ("runs",),
                f"runs times grid cells is {campaign.total_runs()}: at most {MAX_RUNS} runs",
            )
        ]
    # Absolute: the replay lines (replay_line) and the manifests name it so,
    # and a replay runs from the campaign directory or from anywhere.
    mission_path = Path(os.path.abspath(path.parent / campaign.mission))
    if not mission_path.is_file():
        what = "is not a file (a directory, a device or a pipe)"
        said = what if mission_path.exists() else "does not exist"
        return None, [at(("mission",), f"mission file {str(mission_path)!r} {said}")]
    # Read once: the text checked is the text every run and worst run runs, and
    # the one hashed into the manifests, whatever happens to the file since.
    raw, mission_diagnostics = read_source(mission_path)
    if raw is not None and is_campaign_text(raw.decode("utf-8", "replace")):
        # said in one line, as `run CAMPAIGN` says it, not as every campaign key
        # a mission does not know
        return None, [
            at(
                ("mission",),
                f"mission file {str(mission_path)!r} is a campaign, not a mission: "
                "name the mission file a campaign runs (that campaign's own `mission`)",
            )
        ]
    mission = None
    if raw is not None and settings:
        # A setting the campaign's vary would overwrite, said before what it breaks.
        document, _ = read_document(raw.decode("utf-8", "replace"))
        conflicts = _set_and_varied(
            settings, list(campaign.vary), None if document is None else document.data
        )
        if conflicts:
            return None, conflicts
    if raw is not None:
        mission, mission_diagnostics = check_mission_bytes(raw, str(mission_path), settings)
        sources = {setting.source for setting in settings}
        refused = [d for d in mission_diagnostics if d.severity == "error"]
        if refused and all(d.file in sources for d in refused):
            return None, refused  # a bad setting: said as `run --set` says it
    if mission is None or raw is None:
        errors = sum(d.severity == "error" for d in mission_diagnostics)
        count = f"{errors} error{'s' if errors != 1 else ''}"
        return None, [
            at(("mission",), f"mission {str(mission_path)!r} is invalid: {count}, listed with it"),
            *mission_diagnostics,
        ]
    loaded = LoadedCampaign(
        campaign,
        path,
        mission_path,
        raw.decode("utf-8"),
        campaign_sha256=campaign_sha256,
        mission_sha256=hashlib.sha256(raw).hexdigest(),
        settings=settings,
        positions=keys,
    )
    problems = [
        at(("vary", name), problem)
        for name, axis in campaign.vary.items()
        for problem in _axis_problems(name, axis, loaded)
    ]
    data = loaded.mission_document.data
    problems += [
        at(("vary", name), problem) for name, problem in _overlaps(list(campaign.vary), data)
    ]
    if problems:
        return None, problems
    # The mission's warnings, of its own values (each run's drawn values are
    # checked as the run starts): `validate --strict` on a campaign fails on
    # them as on the mission, and a sweep says them before it runs.
    return loaded, [d for d in mission_diagnostics if d.severity == "warning"]


def _set_and_varied(
    settings: Sequence[Override], varied: list[str], mission: Any
) -> list[Diagnostic]:
    """A ``--set`` field that the campaign also varies (or that holds or lies in
    a varied one), or the sensors' seed: every run would write its own value
    over the setting."""
    found = []
    for setting in settings:
        set_path = resolved_path(mission, setting.path)
        if set_path == _SEED_PATH:
            message = (
                "each run's sensor seed is drawn from the campaign's seed; set the "
                "campaign's seed instead"
            )
            found.append(Diagnostic(setting.source, 0, 0, message))
        for name in varied:
            try:
                path = resolved_path(mission, parse_path(name))
            except ValueError:  # said by the axis's own check
                continue
            shorter = min(len(path), len(set_path))
            if path[:shorter] == set_path[:shorter]:
                message = (
                    f"the campaign varies {name!r}, which this sets for every run: "
                    "set a field the campaign does not vary, or change its vary"
                )
                found.append(Diagnostic(setting.source, 0, 0, message))
    return found


def _overlaps(names: list[str], mission: Any) -> list[tuple[str, str]]:
    """Varied paths that are one field, or inside another varied path: each run
    would write one value over the other (into the value a choice or grid
    shares between runs). Paths are compared as they land in the mission: a
    phase by its name or its index is one phase."""
    landed = {}
    for name in names:
        try:
            landed[name] = resolved_path(mission, parse_path(name))
        except ValueError:  # said by its axis's own check
            continue
    first: dict[DataPath, str] = {}
    found = []
    for name, path in landed.items():
        if path in first:  # said at the second
            message = f"vary {name!r} is the same field as {first[path]!r}; vary it once"
            found.append((name, message))
        else:
            first[path] = name
    found += [
        (
            inner,
            f"vary {inner!r} lies inside {outer!r}, also varied; "
            f"vary either {outer!r} or the fields inside it",
        )
        for inner, inner_path in landed.items()
        for outer_path, outer in first.items()
        if len(outer_path) < len(inner_path) and inner_path[: len(outer_path)] == outer_path
    ]
    return found


def _axis_problems(name: str, axis: Axis, loaded: LoadedCampaign) -> list[str]:
    """Why the mission refuses this axis: a malformed path, or the first value it refuses."""
    try:
        data_path = parse_path(name)
    except ValueError as error:
        return [f"vary {shown(repr(name))}: {error}"]
    if data_path == _SEED_PATH:
        return [
            "vary 'sensors.seed': each run's sensor seed is drawn from the campaign's seed; "
            "vary the campaign's seed instead"
        ]
    checked = set()
    for value in axis.extremes():
        text = value_text(value)
        if text in checked:  # a value repeated in a choice: one check
            continue
        checked.add(text)
        if _accepted_without_sampling(name, value, loaded):
            continue
        _, diagnostics = loaded.mission_with([override(name, value)])
        errors = [d for d in diagnostics if d.severity == "error"]
        if errors:
            reasons = "; ".join(_reason(d) for d in errors)
            return [f"vary {shown(repr(name))} ({axis.kind}) at {shown(text)}: {reasons}"]
    return []


def _accepted_without_sampling(name: str, value: Any, loaded: LoadedCampaign) -> bool:
    """Whether the mission accepts ``value`` at ``name`` by its fields and the
    checks across them, where ``name`` is a field the checks that sample paths
    and regions never read: they then say of it what they said of the mission
    (nothing), at a tenth of the cost of checking it whole."""
    try:
        mission = loaded.mission_across_fields([override(name, value)])
        return mission is not None and not read_by_sampling_checks(name, mission)
    except Exception:  # the whole check says what is wrong, at the axis
        return False


def _reason(diagnostic: Diagnostic) -> str:
    if diagnostic.line:  # a check across fields, placed in the mission file
        return f"{diagnostic.message} (at {diagnostic.file}:{diagnostic.line})"
    return diagnostic.message
