"""JSON command scripts (after seed 003): loading, ``${NAME}`` variables, and validated field access.

A script is a JSON list of objects, each with a ``command`` (create, get, set, fix, unfix, run) and fields.
``${NAME}`` anywhere in a string is replaced by the value given with ``-var NAME VALUE``; a string that held
a variable becomes a number when the filled-in text parses as one (``"${N}"``, ``"-${HALF_WIDTH}"``).
"""
from __future__ import annotations

import json
import math
import re
from pathlib import Path

from .errors import InputError

COMMANDS = ("create", "get", "set", "fix", "unfix", "run")
_VARIABLE = re.compile(r"\$\{([A-Za-z_][A-Za-z0-9_]*)\}")


def _number_or_text(text: str):
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def substitute(value, variables: dict[str, str], where: str):
    """value with every ``${NAME}`` filled in; where names the command for error messages."""
    if isinstance(value, str):
        whole = _VARIABLE.fullmatch(value)
        for name in _VARIABLE.findall(value):
            if name not in variables:
                raise InputError(f"{where}: variable '${{{name}}}' has no value (pass -var {name} VALUE)")
        if whole:
            return _number_or_text(variables[whole.group(1)])
        if not _VARIABLE.search(value):
            return value
        # "-${W}" or "${A}e-3": a filled-in string that reads as a number is one
        return _number_or_text(_VARIABLE.sub(lambda m: variables[m.group(1)], value))
    if isinstance(value, list):
        return [substitute(v, variables, where) for v in value]
    if isinstance(value, dict):
        return {k: substitute(v, variables, where) for k, v in value.items()}
    return value


def load_script(path: str, variables: dict[str, str]) -> list[dict]:
    """The command list of a script file (variables not yet filled in; that happens per command)."""
    try:
        text = Path(path).read_text()
    except OSError as exc:
        raise InputError(f"{path}: cannot read input script ({exc.strerror or exc})") from None
    try:
        commands = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not valid JSON: {exc.msg} at line {exc.lineno} column {exc.colno}") from None
    if not isinstance(commands, list):
        raise InputError(f"{path}: the script must be a JSON list of command objects")
    return commands


class Fields:
    """Typed, validated access to one command's fields; every error names file, command and field."""

    def __init__(self, data: dict, where: str):
        self.data = data
        self.where = where
        self.used = {"command"}

    def error(self, field: str, message: str) -> InputError:
        return InputError(f"{self.where}: field '{field}' {message}")

    def has(self, name: str) -> bool:
        return name in self.data

    def _get(self, name, default, required):
        self.used.add(name)
        if name not in self.data:
            if required:
                raise self.error(name, "is missing")
            return default
        return self.data[name]

    def number(self, name, default=None, required=False, positive=False, minimum=None, maximum=None,
               open_minimum=False):
        value = self._get(name, default, required and default is None)
        if value is None:
            return None
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.error(name, f"must be a number, got {json.dumps(value)}")
        value = float(value)
        if positive and value <= 0:
            raise self.error(name, f"must be > 0, got {value:g}")
        if minimum is not None and (value <= minimum if open_minimum else value < minimum):
            raise self.error(name, f"must be {'>' if open_minimum else '>='} {minimum:g}, got {value:g}")
        if maximum is not None and value > maximum:
            raise self.error(name, f"must be <= {maximum:g}, got {value:g}")
        return value

    def integer(self, name, default=None, required=False, minimum=None):
        value = self._get(name, default, required and default is None)
        if value is None:
            return None
        if isinstance(value, bool) or not isinstance(value, int):
            if isinstance(value, float) and value.is_integer():
                value = int(value)
            else:
                raise self.error(name, f"must be an integer, got {json.dumps(value)}")
        if minimum is not None and value < minimum:
            raise self.error(name, f"must be >= {minimum}, got {value}")
        return value

    def string(self, name, default=None, required=False, choices=None):
        value = self._get(name, default, required and default is None)
        if value is None:
            return None
        if not isinstance(value, str):
            raise self.error(name, f"must be a string, got {json.dumps(value)}")
        if choices is not None and value not in choices:
            raise self.error(name, f"must be one of {', '.join(choices)}, got '{value}'")
        return value

    def boolean(self, name, default=None, required=False):
        value = self._get(name, default, required and default is None)
        if not isinstance(value, bool):
            raise self.error(name, f"must be true or false, got {json.dumps(value)}")
        return value

    def vector(self, name, length=3, default=None, required=False):
        value = self._get(name, default, required and default is None)
        if value is None:
            return None
        if (not isinstance(value, list) or len(value) != length
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                           for v in value)):
            raise self.error(name, f"must be a list of {length} numbers, got {json.dumps(value)}")
        return [float(v) for v in value]

    def strings(self, name, default=None, required=False):
        value = self._get(name, default, required and default is None)
        if value is None:
            return None
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise self.error(name, f"must be a list of strings, got {json.dumps(value)}")
        return value

    def mapping(self, name, default=None, required=False):
        value = self._get(name, default, required and default is None)
        if value is None:
            return None
        if not isinstance(value, dict):
            raise self.error(name, f"must be an object, got {json.dumps(value)}")
        return value

    def raw(self, name, default=None, required=False):
        return self._get(name, default, required and default is None)

    def finish(self):
        """Unknown fields are errors too: a typo must not be silently ignored."""
        for name in self.data:
            if name not in self.used:
                raise self.error(name, "is not a field of this command")
