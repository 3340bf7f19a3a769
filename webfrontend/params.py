"""Typed request values: every view reads its query string and path values through this module.

A value the dashboard cannot use is a 400 (query string) or a 404 (path) naming what is wrong - never a 500
from deep inside the database layer. What is refused and why:

- ids: ASCII digits only, 1 to 2**63 - 1. ``str.isdigit()`` is true for '²' and '١' (int() fails on the
  first and reads the second as 1), and 99999999999999999999 overflows SQLite's and PostgreSQL's integers;
- text: no control characters (PostgreSQL rejects NUL in strings), at most a few hundred characters;
- a parameter that takes one value, given several times (``?machine=1&machine=2``): which one was meant?
- path values: no NUL or control characters, no ``.``/``..`` segments, bounded length.
"""
from __future__ import annotations

import re

from django.core.exceptions import BadRequest

from harness.store.models import Run
from harness.store.runrecord import FAILURE_REASONS

#: largest id the store's databases hold (SQLite INTEGER, PostgreSQL bigint of BigAutoField)
MAX_ID = 2 ** 63 - 1
_ASCII_ID = re.compile(r"[0-9]{1,19}")
_CONTROL = re.compile(r"[\x00-\x1f\x7f]")
#: longest text parameter (series and quantity names are at most 200 characters in the store)
MAX_TEXT = 200
#: longest path value (test case paths are at most 500 characters in the store; run files get more room)
MAX_PATH = 1000


class BadParameter(BadRequest):
    """A query parameter the dashboard cannot use; the message names it and says what is allowed.

    ``links`` are ``(label, url)`` pairs the error page offers instead (e.g. one JUnit report per machine).
    """

    def __init__(self, message: str, links: list[tuple[str, str]] | None = None):
        super().__init__(message)
        self.links = links or []


def shown(value: str) -> str:
    """A user-given value for an error message: quoted, cut at 40 characters."""
    return repr(value if len(value) <= 40 else value[:40] + "...")


def _single(query, name: str) -> str | None:
    values = query.getlist(name)
    if len(values) > 1:
        raise BadParameter(f"{name}: given {len(values)} times; give it once")
    return values[0] if values else None


def parse_id(text: str, name: str) -> int:
    if not _ASCII_ID.fullmatch(text) or not 1 <= int(text) <= MAX_ID:
        raise BadParameter(f"{name}: {shown(text)} is not an id (a whole number from 1 to {MAX_ID}, "
                           "in digits 0-9)")
    return int(text)


def optional_id(query, name: str) -> int | None:
    """The id ``name`` names, or None when it is absent or blank."""
    text = _single(query, name)
    return parse_id(text, name) if text else None


def id_list(query, name: str, limit: int, what: str = "ids") -> list[int]:
    """Distinct ids in the order given, from repeated and comma-separated values (``?run=1,2&run=3``).

    More than ``limit`` distinct ids is a BadParameter that says the limit.
    """
    ids: dict[int, None] = {}
    for value in query.getlist(name):
        for part in value.split(","):
            part = part.strip()
            if part:
                ids[parse_id(part, name)] = None
            if len(ids) > limit:
                total = len({p.strip() for v in query.getlist(name) for p in v.split(",") if p.strip()})
                raise BadParameter(f"{name}: at most {limit} {what} at once (got {total}); select fewer")
    return list(ids)


def choice(query, name: str, choices, default: str | None = None) -> str | None:
    """One of ``choices``; ``default`` when absent or blank."""
    text = _single(query, name)
    if not text:
        return default
    if text not in choices:
        raise BadParameter(f"{name}: {shown(text)} is not one of {', '.join(choices)}")
    return text


def text(query, name: str, max_length: int = MAX_TEXT) -> str | None:
    """A short text (a series or quantity name); None when absent or blank."""
    value = _single(query, name)
    if not value:
        return None
    if len(value) > max_length:
        raise BadParameter(f"{name}: longer than {max_length} characters ({len(value)})")
    if _CONTROL.search(value):
        raise BadParameter(f"{name}: {shown(value)} holds control characters")
    return value


def page_number(query, name: str = "page") -> int:
    """A page of a long list, 1 when absent (pages beyond the last show the last)."""
    return optional_id(query, name) or 1


class IdConverter:
    """``<id:run_id>``: an id in the store's range; anything else matches no URL (404)."""

    regex = "[0-9]{1,19}"

    def to_python(self, value: str) -> int:
        number = int(value)
        if not 1 <= number <= MAX_ID:
            raise ValueError(f"id out of range: {value}")
        return number

    def to_url(self, value) -> str:
        return str(int(value))


def path_problem(value: str) -> str | None:
    """Why a path value from a URL cannot name a test case, folder or run file (None: it can)."""
    if len(value) > MAX_PATH:
        return "too long"
    if _CONTROL.search(value):
        return "control characters"
    if any(part in (".", "..") for part in value.split("/")):
        return "a '.' or '..' segment"
    return None


class PathConverter:
    """``<relpath:folder>``: a relative path of one or more segments; a bad one matches no URL (404)."""

    regex = ".+"

    def to_python(self, value: str) -> str:
        problem = path_problem(value)
        if problem:
            raise ValueError(problem)
        return value

    def to_url(self, value) -> str:
        return str(value)


class SegmentConverter(PathConverter):
    """``<segment:name>``: one path segment (no '/')."""

    regex = "[^/]+"


_COMMIT_PREFIX = re.compile(r"[0-9a-fA-F]{1,40}")


def commit_prefix(query, name: str = "commit") -> str | None:
    """The start of a commit id (hex digits, at most 40), lower case; None when absent or blank."""
    value = _single(query, name)
    if not value:
        return None
    if not _COMMIT_PREFIX.fullmatch(value):
        raise BadParameter(f"{name}: {shown(value)} is not the start of a commit id (1 to 40 hex digits 0-9, a-f)")
    return value.lower()


FILTER_NAMES = ("q", "commit", "build", "state", "reason")


def run_filters(query) -> dict:
    """The search and filters of the run lists, each None when not given: ``q`` (a substring of the test
    case path or the run name), ``commit`` (commit prefix of the run's build), ``build`` (build id),
    ``state`` (a run state) and ``reason`` (a failure reason, harness.store.runrecord.FAILURE_REASONS)."""
    return {"q": text(query, "q"), "commit": commit_prefix(query, "commit"), "build": optional_id(query, "build"),
            "state": choice(query, "state", Run.State.values),
            "reason": choice(query, "reason", [r for r in FAILURE_REASONS if r])}
