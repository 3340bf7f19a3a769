"""Reading the harness' JSON input files (targets, run.config) with messages a user can act on.

Every problem is one line naming the file, the JSON path of the offending field (``$.runs[1].nprocs``) and
what is wrong, so that a broken file is reported and the harness goes on with everything else.

JSON has no NaN or Infinity, but Python's json module reads ``NaN``, ``Infinity``, ``-Infinity`` and turns
``1e400`` into infinity. Such a value in a run.config once reached the store (which refuses it) and aborted
a whole ``harness run``. Here they never become floats: ``load_json`` either refuses the file at the first
one (line and column), or - with ``strict=False``, for files whose validation reports problems per JSON
path - keeps each as a ``NonFinite`` marker that ``non_finite_problems`` reports where it stands.
"""
from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from pathlib import Path

from harness.adapters.base import UserError

#: a JSON string, a constant Python's json accepts, or a JSON number - in document order
_TOKEN = re.compile(r'"(?:[^"\\]|\\.)*"|(-?Infinity|NaN|-?(?:0|[1-9]\d*)(?:\.\d+)?(?:[eE][-+]?\d+)?)')


class NonFinite(str):
    """A number JSON cannot carry (``NaN``, ``Infinity``, or beyond the range of a double), kept as its
    text. Being a ``str``, a config holding it still serializes as valid JSON; every type check sees a
    string where a number belongs, and ``non_finite_problems`` names it."""

    line: int = 0
    column: int = 0

    def describe(self) -> str:
        where = f" at line {self.line} column {self.column}" if self.line else ""
        shown = self if len(self) <= 24 else f"{self[:12]}...({len(self)} characters)"
        if self.lstrip("-") in ("NaN", "Infinity"):
            return f"{shown}{where} is not a number JSON allows (NaN and Infinity are refused)"
        return f"{shown}{where} is too large for a number (beyond about 1.8e308)"


def _number_hooks():
    """parse_* hooks that mark non-finite numbers, and the list of (call index, marker) they made."""
    made: list[tuple[int, NonFinite]] = []
    count = [0]

    def mark(text: str) -> NonFinite:
        marker = NonFinite(text)
        made.append((count[0], marker))
        return marker

    def on_constant(text):
        count[0] += 1
        return mark(text)

    def on_float(text):
        count[0] += 1
        value = float(text)
        return value if math.isfinite(value) else mark(text)

    def on_int(text):
        count[0] += 1
        try:
            value = int(text)
            float(value)  # a double must hold it: timeouts, tolerances and the store are doubles
        except (ValueError, OverflowError):  # ValueError: more digits than Python converts
            return mark(text)
        return value

    return made, count, dict(parse_constant=on_constant, parse_float=on_float, parse_int=on_int)


def _locate(text: str, made: list[tuple[int, NonFinite]]) -> None:
    """Give each marker its line and column: the json module calls one hook per number, in document
    order, so the n-th hook call is the n-th number token outside strings."""
    wanted = dict(made)
    number = 0
    for match in _TOKEN.finditer(text):
        if match.group(1) is None:
            continue  # a string
        number += 1
        if number in wanted:
            offset = match.start(1)
            wanted[number].line = text.count("\n", 0, offset) + 1
            wanted[number].column = offset - (text.rfind("\n", 0, offset) + 1) + 1
            if number == max(wanted):
                return


class JsonFileError(UserError):
    """A file that is no JSON the harness reads (missing, not UTF-8, a syntax error, NaN): ``problem`` says
    what, without the file's name."""

    def __init__(self, path, problem: str):
        super().__init__(f"{path}: {problem}")
        self.problem = problem


def load_json(path: Path, strict: bool = True):
    """Parse ``path``; a syntax error becomes a UserError with line and column.

    ``strict``: a NaN, Infinity or out-of-range number is a UserError naming its line and column. Otherwise
    it is returned as a ``NonFinite`` marker, for validation to report with its JSON path.
    """
    try:
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise JsonFileError(path, "file not found") from None
    except UnicodeDecodeError as exc:
        raise JsonFileError(path, f"not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except OSError as exc:
        raise JsonFileError(path, f"cannot read ({exc.strerror})") from None
    made, _count, hooks = _number_hooks()
    try:
        data = json.loads(text, **hooks)
    except json.JSONDecodeError as exc:
        raise JsonFileError(path, f"invalid JSON at line {exc.lineno} column {exc.colno}: {exc.msg}") from None
    except RecursionError:
        raise JsonFileError(path, "invalid JSON: nested too deeply") from None
    if made:
        _locate(text, made)
        if strict:
            raise JsonFileError(path, made[0][1].describe())
    return data


def non_finite_problems(problems: "Problems", value, *where) -> None:
    """Report every ``NonFinite`` marker inside ``value`` (found at JSON path ``where``)."""
    if isinstance(value, NonFinite):
        problems.add(where, value.describe())
    elif isinstance(value, dict):
        for key, item in value.items():
            non_finite_problems(problems, item, *where, key)
    elif isinstance(value, list):
        for i, item in enumerate(value):
            non_finite_problems(problems, item, *where, i)


def has_non_finite(value) -> bool:
    if isinstance(value, NonFinite):
        return True
    if isinstance(value, dict):
        return any(has_non_finite(item) for item in value.values())
    if isinstance(value, list):
        return any(has_non_finite(item) for item in value)
    return False


def json_path(*parts) -> str:
    """``json_path("runs", 1, "nprocs")`` -> ``$.runs[1].nprocs``."""
    out = "$"
    for part in parts:
        out += f"[{part}]" if isinstance(part, int) else f".{part}"
    return out


@dataclass(frozen=True)
class Problem:
    """One problem of a file: where (the JSON path as parts, ``("runs", 1, "nprocs")``; ``()`` is the whole
    document) and what is wrong. ``label`` names a place that is no JSON path (``file name``)."""

    path: tuple
    message: str
    label: str | None = None

    def where(self) -> str:
        """``$.runs[1].nprocs``, the label, or "" for a problem of the file as such (not JSON at all)."""
        return json_path(*self.path) if self.label is None else self.label

    def line(self, file) -> str:
        """The one line a user reads: ``FILE: $.runs[1].nprocs: must be at least 1``."""
        return f"{file}: {self.where()}: {self.message}" if self.where() else f"{file}: {self.message}"


class Problems:
    """The problems of one file, in the order found."""

    def __init__(self, path: Path):
        self.path = Path(path)
        self.found: list[Problem] = []

    def add(self, where, what: str) -> None:
        """A problem at JSON path ``where`` (parts: ``("runs", 1)``), or at a place a label names."""
        problem = Problem(tuple(where), what) if isinstance(where, (tuple, list)) else Problem((), what, where)
        self.found.append(problem)

    def extend(self, problems) -> None:
        self.found.extend(problems)

    @property
    def messages(self) -> list[str]:
        return [problem.line(self.path) for problem in self.found]

    def at(self, path: tuple) -> list[Problem]:
        """The problems at ``path`` or below it."""
        return [p for p in self.found if p.path[:len(path)] == path and p.label is None]

    def __bool__(self):
        return bool(self.found)

    def raise_if_any(self) -> None:
        if self.found:
            raise UserError("; ".join(self.messages))
