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
#: largest integer field (step counts, intervals, seeds): the step loop counts in int64, and 2**53 keeps every
#: step exactly representable as the double a thermo file prints
MAX_INTEGER = 2 ** 53
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


#: deepest nesting of lists and objects a script may have; real scripts need 4 (list, command, region, list)
MAX_NESTING = 32


def _depth(value) -> int:
    """Nesting depth of parsed JSON, without recursion (a deep value must not exhaust the Python stack)."""
    deepest, stack = 0, [(value, 0)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, (list, dict)):
            depth += 1
            deepest = max(deepest, depth)
            if depth > MAX_NESTING:
                break
            stack.extend((v, depth) for v in (item.values() if isinstance(item, dict) else item))
    return deepest


def load_script(path: str, variables: dict[str, str]) -> list[dict]:
    """The command list of a script file (variables not yet filled in; that happens per command)."""
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read input script ({exc.strerror or exc})") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not a UTF-8 text file (byte 0x{data[exc.start]:02x} at offset {exc.start}); "
                         "scripts are JSON, which is UTF-8") from None
    try:
        commands = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not valid JSON: {exc.msg} at line {exc.lineno} column {exc.colno}") from None
    except RecursionError:
        raise InputError(f"{path}: lists or objects nest deeper than the JSON parser allows "
                         f"(a script nests at most {MAX_NESTING} levels)") from None
    except ValueError as exc:  # e.g. an integer literal longer than Python's 4300-digit conversion limit
        raise InputError(f"{path}: not valid JSON: {exc}") from None
    if _depth(commands) > MAX_NESTING:
        raise InputError(f"{path}: lists or objects nest deeper than {MAX_NESTING} levels")
    if not isinstance(commands, list):
        raise InputError(f"{path}: the script must be a JSON list of command objects")
    return commands


def _real(value):
    """value as a finite float, or None when it is not a number or not representable (10**400, NaN, inf)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    try:
        value = float(value)
    except OverflowError:
        return None
    return value if math.isfinite(value) else None


def _shown(value) -> str:
    """A field value for an error message, kept short (a 5000-digit number must not make a 5000-char line)."""
    try:
        text = json.dumps(value)
    except (ValueError, RecursionError):
        text = repr(value)
    return text if len(text) <= 80 else text[:60] + "..." + text[-10:]


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
        number = _real(value)
        if number is None:
            raise self.error(name, f"must be a number (finite, within double precision), got {_shown(value)}")
        value = number
        if positive and value <= 0:
            raise self.error(name, f"must be > 0, got {value:g}")
        if minimum is not None and (value <= minimum if open_minimum else value < minimum):
            raise self.error(name, f"must be {'>' if open_minimum else '>='} {minimum:g}, got {value:g}")
        if maximum is not None and value > maximum:
            raise self.error(name, f"must be <= {maximum:g}, got {value:g}")
        return value

    def integer(self, name, default=None, required=False, minimum=None, maximum=MAX_INTEGER):
        value = self._get(name, default, required and default is None)
        if value is None:
            return None
        if isinstance(value, bool) or not isinstance(value, int):
            if isinstance(value, float) and value.is_integer():
                value = int(value)
            else:
                raise self.error(name, f"must be an integer, got {_shown(value)}")
        if minimum is not None and value < minimum:
            raise self.error(name, f"must be >= {minimum}, got {_shown(value)}")
        if maximum is not None and value > maximum:
            raise self.error(name, f"must be <= {maximum}, got {_shown(value)}")
        return value

    def string(self, name, default=None, required=False, choices=None):
        value = self._get(name, default, required and default is None)
        if value is None:
            return None
        if not isinstance(value, str):
            raise self.error(name, f"must be a string, got {_shown(value)}")
        if choices is not None and value not in choices:
            raise self.error(name, f"must be one of {', '.join(choices)}, got '{value}'")
        return value

    def boolean(self, name, default=None, required=False):
        value = self._get(name, default, required and default is None)
        if not isinstance(value, bool):
            raise self.error(name, f"must be true or false, got {_shown(value)}")
        return value

    def vector(self, name, length=3, default=None, required=False):
        value = self._get(name, default, required and default is None)
        if value is None:
            return None
        numbers = [_real(v) for v in value] if isinstance(value, list) else []
        if len(numbers) != length or any(v is None for v in numbers):
            raise self.error(name, f"must be a list of {length} numbers (finite, within double precision), got "
                             f"{_shown(value)}")
        return numbers

    def strings(self, name, default=None, required=False):
        value = self._get(name, default, required and default is None)
        if value is None:
            return None
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise self.error(name, f"must be a list of strings, got {_shown(value)}")
        return value

    def mapping(self, name, default=None, required=False):
        value = self._get(name, default, required and default is None)
        if value is None:
            return None
        if not isinstance(value, dict):
            raise self.error(name, f"must be an object, got {_shown(value)}")
        return value

    def raw(self, name, default=None, required=False):
        return self._get(name, default, required and default is None)

    def finish(self):
        """Unknown fields are errors too: a typo must not be silently ignored."""
        for name in self.data:
            if name not in self.used:
                raise self.error(name, "is not a field of this command")
