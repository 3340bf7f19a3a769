"""Validating a file against its model: each problem a ``Problem`` (JSON path, message), in the words of the
field (``Says``), never pydantic's own.

pydantic reports an error per branch of a union (``script`` is a string or an object: two errors for a
number); they become one problem at the field. Where the value is an object and one branch is a model, the
model's own errors are the ones reported (``stability.finite``, not "stability must be false").
"""
from __future__ import annotations

import json
import types
import typing
from dataclasses import dataclass

from pydantic import BaseModel, ValidationError

from harness.config.jsonfile import NonFinite, Problem

Path = tuple  # JSON path parts: ("runs", 1, "nprocs")


@dataclass(frozen=True)
class Says:
    """How problems of a field are worded (in ``Annotated[...]`` of the field, or ``says`` of a model).

    ``what``: what the value must be, "a list of folders" -> ``must be a list of folders, got string "x"``;
    ``item``: the same for each item of a list or value of an object; ``bound``: the message when a bound or
    choice is not met, ``item_bound`` for items (``{value!r}`` and ``{known}``, the choices, may appear);
    ``message``: one message for every problem of the field; ``missing``: when it is absent (default
    ``required``); ``unknown``: a model's message for a field it does not know (``{known}``, ``{field}``);
    ``unknown_here``: that message is given once at the object, naming all unknown fields (``{fields}``)."""

    what: str = ""
    item: str = ""
    bound: str = ""
    item_bound: str = ""
    message: str = ""
    missing: str = "required"
    unknown: str = "unknown field (known: {known})"
    unknown_here: bool = False


def validate(model: type[BaseModel], data, at: Path = ()) -> tuple[BaseModel | None, list[Problem]]:
    """``data`` as a ``model`` (None when it has problems) and its problems, paths prefixed with ``at``."""
    try:
        return model.model_validate(data), []
    except ValidationError as exc:
        errors = exc.errors(include_url=False)
    found: dict[Path, list] = {}
    unknown: dict[Path, list] = {}  # fields the model at a path does not know, by that path
    for error in errors:
        if isinstance(error["input"], NonFinite):
            continue  # a NaN or 1e400 is reported once, where it stands (harness.config.jsonfile.non_finite_problems)
        path, tagged = _data_path(data, error)
        if error["type"] == "extra_forbidden":
            unknown.setdefault(path[:-1], []).append(path[-1])
        else:
            found.setdefault(path, []).append((error, tagged))
    problems = []
    for path, path_errors in found.items():
        below = [*found, *((*parent, field) for parent, fields in unknown.items() for field in fields)]
        deeper = any(other[:len(path)] == path and len(other) > len(path) for other in below)
        problems += _problems_at(model, path, path_errors, deeper, at)
    for path, fields in unknown.items():
        problems += _unknown(model, path, fields, at)
    return None, _unique(problems)


def _unique(problems: list[Problem]) -> list[Problem]:
    return list(dict.fromkeys(problems))


def _data_path(data, error) -> tuple[Path, bool]:
    """The error's location as a path into ``data``, without pydantic's union branch names; and whether
    the error is one branch's (the value as a whole matched no branch of a union)."""
    path, value, tagged = [], data, False
    loc = error["loc"]
    for k, part in enumerate(loc):
        if isinstance(value, dict) and isinstance(part, str) and part in value:
            path.append(part)
            value, tagged = value[part], False
        elif isinstance(value, list) and isinstance(part, int) and 0 <= part < len(value):
            path.append(part)
            value, tagged = value[part], False
        elif error["type"] == "missing" and k == len(loc) - 1:
            path.append(part)
            tagged = False
        else:
            tagged = True  # a union branch's name (str, dict[str,str], Stability)
    return tuple(path), tagged


def _problems_at(model, path: Path, errors: list, deeper: bool, at: Path) -> list[Problem]:
    """The problems of the value at ``path`` from pydantic's ``errors`` there (pairs of the error and whether
    it is one union branch's); ``deeper``: there are errors below ``path`` too."""
    if deeper or any(not _is_type_error(error) for error, _t in errors):
        # a branch of a union took the kind of value; its own errors (below, or of a bound) say what is wrong
        errors = [(error, tagged) for error, tagged in errors if not (tagged and _is_type_error(error))]
    says, is_item, choices = _says_at(model, path)
    problems = []
    branches = [error for error, tagged in errors if tagged and _is_type_error(error)]
    if branches:  # no branch of a union took the value: one problem for all of them
        what = (says.item if is_item else says.what) or " or ".join(dict.fromkeys(map(_default_what, branches)))
        message = says.message or f"must be {what}, got {describe(branches[0]['input'])}"
        problems.append(Problem(at + path, message))
    for error, tagged in errors:
        if not (tagged and _is_type_error(error)):
            problems.append(Problem(at + path, _message(error, says, is_item, choices)))
    return problems


def _unknown(model, parent: Path, fields: list, at: Path) -> list[Problem]:
    """Problems of the fields the object at ``parent`` has but its model does not know."""
    owner = _model_at(model, parent)
    says = getattr(owner, "says", Says())
    known = ", ".join(sorted(info.alias or name for name, info in owner.model_fields.items()))
    if says.unknown_here:
        return [Problem(at + parent, says.unknown.format(fields=", ".join(sorted(map(str, fields))), known=known))]
    return [Problem(at + (*parent, field), says.unknown.format(known=known, field=field)) for field in fields]


def _is_type_error(error) -> bool:
    """The value is of the wrong JSON kind (also: not the ``false`` a ``false or {...}`` field takes)."""
    return error["type"].endswith("_type") or error["type"] == "literal_error" and error["input"] is not False \
        and "False" in str((error.get("ctx") or {}).get("expected"))


def _message(error, says: Says, is_item: bool, choices) -> str:
    value = error["input"]
    if says.message:
        return says.message.format(value=value, known=", ".join(map(str, choices)))
    kind = error["type"]
    if kind == "missing":
        return says.missing
    if kind.endswith("_type"):
        what = (says.item if is_item else says.what) or _default_what(error)
        return f"must be {what}, got {describe(value)}"
    bound = says.item_bound if is_item else says.bound
    if bound:
        return bound.format(value=value, known=", ".join(map(str, choices)))
    return _default_bound(error)


def _default_what(error) -> str:
    return {"string_type": "a string", "int_type": "an integer", "float_type": "a number",
            "bool_type": "true or false", "list_type": "a list", "dict_type": "an object",
            "model_type": "an object", "model_attributes_type": "an object",
            "literal_error": "false"}.get(error["type"], "valid")


def _default_bound(error) -> str:
    ctx = error.get("ctx") or {}
    if error["type"] == "literal_error":
        return f"must be one of {ctx.get('expected', '').replace(chr(39), '')}, got {error['input']!r}"
    if error["type"] in ("greater_than_equal", "greater_than", "less_than_equal"):
        sign = {"greater_than_equal": ">=", "greater_than": ">", "less_than_equal": "<="}[error["type"]]
        return f"must be {sign} {next(iter(ctx.values()))}, got {error['input']!r}"
    if error["type"] == "too_short":
        return f"must hold at least {ctx.get('min_length')}"
    if error["type"] == "string_pattern_mismatch":
        return f"{error['input'][:60]!r} is not of the expected form"
    return error["msg"]


def describe(value) -> str:
    """``string "ten"``, ``list ["a"]``, ``true``, ``null``: the JSON kind and (the start of) the value."""
    text = json.dumps(value)
    text = text if len(text) <= 60 else text[:57] + "..."
    kind = {dict: "object", list: "list", str: "string", int: "integer", float: "number"}.get(type(value))
    return f"{kind} {text}" if kind else text


# ------------------------------------------------------------------------------ the field a path points at

def _locate(model, path: Path):
    """(the model holding the field, its FieldInfo or None, how many items below the field ``path`` ends)."""
    current, info, depth = model, None, 0
    for part in path:
        if info is not None:
            annotation = _unwrap(info.annotation, depth)
            inner = _model_in(annotation) if annotation is not None and _item_type(annotation) is None else None
            if inner is None:
                depth += 1
                continue
            current, depth = inner, 0  # the value here is an object of model ``inner``: part is its field
        info = current.model_fields.get(_field_name(current, part))
        if info is None:
            return current, None, 0
    return current, info, depth


def _model_at(model, path: Path):
    """The model the object at ``path`` is validated as."""
    current, info, depth = _locate(model, path)
    if info is None:
        return current
    return _model_in(_unwrap(info.annotation, depth)) or current


def _says_at(model, path: Path) -> tuple[Says, bool, tuple]:
    """The ``Says`` of the field at ``path``, whether the path is an item of that field, and its choices."""
    current, info, depth = _locate(model, path)
    if info is None:
        return getattr(current, "says", Says()), False, ()
    says = next((m for m in info.metadata if isinstance(m, Says)), None) \
        or next((m for m in _annotated_metadata(info.annotation) if isinstance(m, Says)), Says())
    return says, depth > 0, _choices(_unwrap(info.annotation, depth) if depth else info.annotation)


def _field_name(model, key) -> str:
    for name, info in model.model_fields.items():
        if (info.alias or name) == key:
            return name
    return key


def _strip(annotation):
    """``Annotated[X, ...]`` -> X; ``X | None`` -> X."""
    while True:
        origin, args = typing.get_origin(annotation), typing.get_args(annotation)
        if origin is typing.Annotated:
            annotation = args[0]
        elif origin in (typing.Union, types.UnionType) and type(None) in args and len(args) == 2:
            annotation = next(a for a in args if a is not type(None))
        else:
            return annotation


def _annotated_metadata(annotation) -> list:
    found = []
    while True:
        origin, args = typing.get_origin(annotation), typing.get_args(annotation)
        if origin is typing.Annotated:
            found += list(args[1:])
            annotation = args[0]
        elif origin in (typing.Union, types.UnionType) and type(None) in args and len(args) == 2:
            annotation = next(a for a in args if a is not type(None))
        else:
            return found


def _item_type(annotation):
    """The type of an item of a list or a value of an object (of the list/object branch of a union)."""
    annotation = _strip(annotation)
    origin, args = typing.get_origin(annotation), typing.get_args(annotation)
    if origin is list:
        return args[0]
    if origin is dict:
        return args[1]
    if origin in (typing.Union, types.UnionType):
        for arg in args:
            inner = _item_type(arg)
            if inner is not None:
                return inner
    return None


def _unwrap(annotation, depth: int):
    for _ in range(depth):
        annotation = _item_type(annotation)
        if annotation is None:
            return None
    return annotation


def _model_in(annotation):
    annotation = _strip(annotation)
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in typing.get_args(annotation):
        found = _model_in(arg)
        if found is not None:
            return found
    return None


def _choices(annotation) -> tuple:
    annotation = _strip(annotation)
    if typing.get_origin(annotation) is typing.Literal:
        return typing.get_args(annotation)
    for arg in typing.get_args(annotation):
        found = _choices(arg)
        if found:
            return found
    return ()
