"""Reading the harness' JSON input files (targets, run.config) with messages a user can act on.

Every problem is one line naming the file, the JSON path of the offending field (``$.runs[1].nprocs``) and
what is wrong, so that a broken file is reported and the harness goes on with everything else.
"""
from __future__ import annotations

import json
from pathlib import Path

from harness.adapters.base import UserError


def load_json(path: Path):
    """Parse ``path``; a syntax error becomes a UserError with line and column."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise UserError(f"{path}: file not found") from None
    except UnicodeDecodeError as exc:
        raise UserError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except OSError as exc:
        raise UserError(f"{path}: cannot read ({exc.strerror})") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise UserError(f"{path}: invalid JSON at line {exc.lineno} column {exc.colno}: {exc.msg}") from None


def json_path(*parts) -> str:
    """``json_path("runs", 1, "nprocs")`` -> ``$.runs[1].nprocs``."""
    out = "$"
    for part in parts:
        out += f"[{part}]" if isinstance(part, int) else f".{part}"
    return out


class Problems:
    """Collects validation messages for one file."""

    def __init__(self, path: Path):
        self.path = Path(path)
        self.messages: list[str] = []

    def add(self, where: str, what: str) -> None:
        self.messages.append(f"{self.path}: {where}: {what}")

    def __bool__(self):
        return bool(self.messages)

    def raise_if_any(self) -> None:
        if self.messages:
            raise UserError("; ".join(self.messages))


def expect_type(problems: Problems, where: str, value, types, what: str) -> bool:
    """Record a problem unless ``value`` is an instance of ``types`` (bool is never a number here)."""
    ok = isinstance(value, types) and not (isinstance(value, bool) and bool not in _as_tuple(types))
    if not ok:
        problems.add(where, f"must be {what}, got {type(value).__name__} {json.dumps(value)[:60]}")
    return ok


def _as_tuple(types):
    return types if isinstance(types, tuple) else (types,)
