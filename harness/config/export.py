"""The schema of each file kind as JSON Schema (draft 2020-12) and the run.config reference as Markdown."""
from __future__ import annotations

import re
import textwrap
import types
import typing

from annotated_types import Ge, Gt, Le, MaxLen, MinLen
from pydantic import BaseModel
from pydantic.json_schema import GenerateJsonSchema

from harness.config.adapter import AdapterFile
from harness.config.record import RunRecord
from harness.config.runconfig import RunConfig, RunConfigEntry
from harness.config.target import Target

#: the file kinds ``harness schema`` knows, by the name a user types
KINDS: dict[str, type[BaseModel]] = {"run.config": RunConfig, "target": Target, "adapter": AdapterFile,
                                     "record": RunRecord}
_TITLES = {"run.config": "run.config of a test case", "target": "target definition (targets/NAME.json)",
           "adapter": "generic adapter definition file", "record": "run record (run.json)"}


class _InputSchema(GenerateJsonSchema):
    """An optional field of an input file is left out, never written as null (its readers refuse null): its
    schema is the type alone."""

    def nullable_schema(self, schema):
        return self.generate_inner(schema["schema"])


def json_schema(kind: str) -> dict:
    """The JSON Schema of the file kind ``kind`` (a key of ``KINDS``), for editors and validators. A run record
    may hold null (an exit code of a run that never started); the input files may not."""
    generator = GenerateJsonSchema if kind == "record" else _InputSchema
    schema = KINDS[kind].model_json_schema(by_alias=True, schema_generator=generator)
    if kind != "record":
        _drop_null_defaults(schema)
    return {"$schema": "https://json-schema.org/draft/2020-12/schema",
            "$id": f"https://dem-harness.invalid/schemas/{kind}.json",
            **schema, "title": f"harness {_TITLES[kind]}"}


def _drop_null_defaults(node) -> None:
    """``"default": null`` of an input file's optional field says nothing a reader can use: left out."""
    if isinstance(node, dict):
        if "default" in node and node["default"] is None:
            del node["default"]
        for value in node.values():
            _drop_null_defaults(value)
    elif isinstance(node, list):
        for value in node:
            _drop_null_defaults(value)


# -------------------------------------------------------------------------------------------------- markdown

_GENERATED = ("<!-- generated from harness/config/runconfig.py by `harness schema run.config --markdown`; "
              "edit the models there, then regenerate -->")


def markdown() -> str:
    """docs/run-config.md: the run.config reference, from the models' docstrings and field descriptions."""
    out = [_GENERATED, "", "# run.config reference", "", _prose(RunConfig.__doc__), "",
           "## A run configuration", "", _prose(RunConfigEntry.__doc__), "", _table(RunConfigEntry)]
    seen = {RunConfig, RunConfigEntry}
    for model in _nested_models(RunConfigEntry):
        if model in seen:
            continue
        seen.add(model)
        out += ["", f"## {_anchor(model)}", ""]
        if model.__doc__:
            out += [_prose(model.__doc__), ""]
        out.append(_table(model))
    return "\n".join(out) + "\n"


def _anchor(model) -> str:
    return model.__name__


def _nested_models(model) -> list[type[BaseModel]]:
    """Models used by ``model``'s fields, depth first in field order."""
    found = []
    for info in model.model_fields.values():
        for inner in _models_in(info.annotation):
            if inner not in found:
                found.append(inner)
                found += [m for m in _nested_models(inner) if m not in found]
    return found


def _models_in(annotation) -> list:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [m for arg in typing.get_args(annotation) for m in _models_in(arg)]


def _table(model) -> str:
    rows = ["| field | type | default | what it is |", "| --- | --- | --- | --- |"]
    for name, info in model.model_fields.items():
        default = "required" if info.is_required() else _default(info.get_default(call_default_factory=True))
        text = " ".join((info.description or "").split())
        rows.append(f"| `{info.alias or name}` | {_type_text(info.annotation, info.metadata)} | {default} | "
                    f"{_rst(text)} |")
    return "\n".join(rows)


def _default(value) -> str:
    if value is None or value == {} or value == []:
        return ""
    if isinstance(value, BaseModel):
        return "(below)"
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    if isinstance(value, str):
        return f'`"{value}"`'
    return f"`{value!r}`".replace("'", '"')


def _type_text(annotation, metadata=()) -> str:
    """A reader's words for a field's type: ``list of number > 0``, ``string or object``."""
    bounds = "".join(_bound(m) for m in metadata)
    origin, args = typing.get_origin(annotation), typing.get_args(annotation)
    if origin is typing.Annotated:
        return _type_text(args[0], [*args[1:], *metadata])
    if origin is typing.Literal:
        return " \\| ".join(f"`{'false' if a is False else a}`" for a in args)
    if origin in (typing.Union, types.UnionType):
        parts = [_type_text(a) for a in args if a is not type(None)]
        if "number" in parts and "integer" in parts:
            parts.remove("integer")  # every integer is a number
        return " or ".join(dict.fromkeys(parts)) + bounds
    if origin is list:
        return f"list of {_type_text(args[0])}{bounds}"
    if origin is dict:
        return f"object of {_type_text(args[1])}" if args else "object"
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return f"[{annotation.__name__}](#{annotation.__name__.lower()})"
    return {str: "string", int: "integer", float: "number", bool: "boolean", dict: "object",
            list: "list"}.get(annotation, str(annotation)) + bounds


def _bound(meta) -> str:
    for kind, sign in ((Ge, ">="), (Gt, ">"), (Le, "<=")):
        if isinstance(meta, kind):
            return f" {sign} {getattr(meta, kind.__name__.lower())}"
    if isinstance(meta, MinLen):
        return f" (at least {meta.min_length})"
    if isinstance(meta, MaxLen):
        return f" (at most {meta.max_length})"
    for sub in getattr(meta, "metadata", ()):
        return _bound(sub)
    return ""


def _rst(text: str) -> str:
    return text.replace("``", "`").replace("|", "\\|")


def _prose(doc: str | None) -> str:
    """A docstring as Markdown: ``x`` -> `x`; a paragraph ending in ``::`` is followed by a JSON block."""
    text = textwrap.dedent("\n".join((doc or "").split("\n")[1:]))
    first = (doc or "").split("\n")[0].strip()
    text = first + "\n" + text
    out = []
    for block in re.split(r"\n\s*\n", text.strip()):
        lines = block.split("\n")
        if all(line.startswith("    ") for line in lines if line.strip()):
            out.append("```json\n" + textwrap.dedent(block) + "\n```")
            continue
        paragraph = " ".join(line.strip() for line in lines)
        if paragraph.endswith("::"):
            paragraph = paragraph[:-1]
        out.append(_rst(paragraph).replace("\\|", "|"))
    return "\n\n".join(out)
