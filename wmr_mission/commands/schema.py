"""JSON Schema and the field reference, both generated from the mission models.

``schemas/mission.schema.json`` and the reference part of
``docs/mission-format.md`` are checked in; tests fail when either differs from
what this module generates. Regenerate both with
``python -m wmr_mission.commands.schema``.
"""

from __future__ import annotations

import json
import typing
from pathlib import Path
from typing import Any, Final

from pydantic import BaseModel
from pydantic.fields import FieldInfo
from pydantic_core import PydanticUndefined

from wmr_mission.fields import Registry
from wmr_mission.spec.models import Mission

__all__ = [
    "REFERENCE_BEGIN",
    "REFERENCE_END",
    "campaign_schema_text",
    "reference_markdown",
    "schema_dict",
    "schema_text",
    "write_generated_files",
]

REFERENCE_BEGIN: Final = "<!-- BEGIN GENERATED REFERENCE: python -m wmr_mission.commands.schema -->"
REFERENCE_END: Final = "<!-- END GENERATED REFERENCE -->"


def schema_dict() -> dict[str, Any]:
    """The mission JSON Schema (draft 2020-12)."""
    schema = Mission.model_json_schema(mode="validation")
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        **schema,
    }


def schema_text() -> str:
    """The schema as text: sorted keys, two-space indent, final newline (stable in git)."""
    return _text(schema_dict())


def campaign_schema_text() -> str:
    """The campaign JSON Schema (draft 2020-12), as text like the mission's."""
    from wmr_mission.campaign.models import Campaign

    schema = Campaign.model_json_schema(mode="validation")
    return _text({"$schema": "https://json-schema.org/draft/2020-12/schema", **schema})


def _text(schema: dict[str, Any]) -> str:
    return json.dumps(schema, indent=2, sort_keys=True, ensure_ascii=False) + "\n"


# --- field reference -----------------------------------------------------------


def _registry(annotation: Any) -> Registry[Any] | None:
    """The registry whose variants an annotation takes (wmr_mission.fields.Registry)."""
    if typing.get_origin(annotation) is not typing.Annotated:
        return None
    return next((m for m in typing.get_args(annotation)[1:] if isinstance(m, Registry)), None)


def _models(annotation: Any) -> list[type[BaseModel]]:
    """Models mentioned anywhere in an annotation, in order."""
    registry = _registry(annotation)
    if registry is not None:
        return [variant.settings for variant in registry]
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    found: list[type[BaseModel]] = []
    for argument in typing.get_args(annotation):
        for model in _models(argument):
            if model not in found:
                found.append(model)
    return found


def _all_models() -> list[type[BaseModel]]:
    ordered: list[type[BaseModel]] = []
    pending: list[type[BaseModel]] = [Mission]
    while pending:
        model = pending.pop(0)
        if model in ordered:
            continue
        ordered.append(model)
        for info in model.model_fields.values():
            pending.extend(m for m in _models(info.rebuild_annotation()) if m not in ordered)
    return ordered


def _type_text(annotation: Any) -> str:
    """A short human name for a field type, as written in YAML."""
    origin, arguments = typing.get_origin(annotation), typing.get_args(annotation)
    registry = _registry(annotation)
    if registry is not None:
        return " \\| ".join(_type_text(variant.settings) for variant in registry)
    if origin is typing.Annotated:
        metadata = " ".join(repr(m) for m in arguments[1:])
        if "_evaluate_scalar" in metadata:
            return "scalar"
        if "_number_as_text" in metadata:
            return "expression of t"
        if "_start_angle" in metadata:
            return "'current' \\| scalar"
        return _type_text(arguments[0])
    if origin is typing.Literal:
        return " \\| ".join(f"`{a}`" if isinstance(a, str) else str(a) for a in arguments)
    if origin in (typing.Union, type(int | str)):
        return " \\| ".join(_type_text(a) for a in arguments)
    if origin is list:
        return f"list of {_type_text(arguments[0])}"
    if origin is tuple:
        if len(arguments) == 2 and arguments[1] is Ellipsis:
            return f"list of {_type_text(arguments[0])}"
        return "[" + ", ".join(_type_text(a) for a in arguments) + "]"
    if origin is dict:
        return f"map of {_type_text(arguments[0])} to {_type_text(arguments[1])}"
    if annotation is type(None):
        return "null"
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return f"[{annotation.__name__}](#{annotation.__name__.lower()})"
    return _PLAIN_NAMES.get(annotation, getattr(annotation, "__name__", str(annotation)))


_PLAIN_NAMES: Final[dict[Any, str]] = {
    float: "number",
    int: "integer",
    str: "text",
    bool: "boolean",
}


def _default_text(info: FieldInfo) -> str:
    if info.is_required():
        return "required"
    factory = info.default_factory
    value = factory() if factory is not None else info.default  # type: ignore[call-arg]
    if value is PydanticUndefined:
        return "required"
    if isinstance(value, BaseModel):
        return "see below" if value.model_dump() else "`{}`"
    text = json.dumps(value, default=list)
    return f"`{text}`"


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ") if "\\|" not in text else text


def reference_markdown() -> str:
    """Markdown reference of every mission field, one table per model."""
    lines: list[str] = []
    for model in _all_models():
        lines.append(f"### {model.__name__}")
        lines.append("")
        lines.append(" ".join((model.__doc__ or "").split()))
        lines.append("")
        if not model.model_fields:
            lines.append("No fields: write an empty mapping `{}`.")
            lines.append("")
            continue
        lines.append("| field | type | default | description |")
        lines.append("|---|---|---|---|")
        for name, info in model.model_fields.items():
            annotation = info.rebuild_annotation()
            row = [
                f"`{name}`",
                _type_text(annotation),
                _default_text(info),
                _cell(info.description or ""),
            ]
            lines.append("| " + " | ".join(row) + " |")
        lines.append("")
    return "\n".join(lines)


def replace_reference(document: str) -> str:
    """``document`` with the text between the reference markers regenerated."""
    head, _, rest = document.partition(REFERENCE_BEGIN)
    _, _, tail = rest.partition(REFERENCE_END)
    return f"{head}{REFERENCE_BEGIN}\n\n{reference_markdown()}\n{REFERENCE_END}{tail}"


def write_generated_files(root: Path) -> None:
    """Rewrite the checked-in schema and the reference section of the format doc."""
    (root / "schemas").mkdir(exist_ok=True)
    (root / "schemas" / "mission.schema.json").write_text(schema_text(), encoding="utf-8")
    (root / "schemas" / "campaign.schema.json").write_text(campaign_schema_text(), encoding="utf-8")
    doc = root / "docs" / "mission-format.md"
    doc.write_text(replace_reference(doc.read_text(encoding="utf-8")), encoding="utf-8")


if __name__ == "__main__":
    write_generated_files(Path(__file__).resolve().parents[2])
