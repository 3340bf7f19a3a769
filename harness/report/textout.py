"""Tables and messages for a terminal: the CLI's default output fits ``WIDTH`` columns (120), ``--wide``
prints everything as it is.

A progress line too wide (``fit_line``) cuts its message first, then the run's name in the middle.
A table too wide for the terminal shrinks its text columns (a column with a cell longer than
``TEXT_CELL`` characters: test case paths, messages), the widest first, and cuts their cells with an ellipsis;
short columns (commits, states, numbers) are never cut.
"""
from __future__ import annotations

import textwrap

#: the width the CLI's tables and messages fit by default (characters)
DEFAULT_WIDTH = 120
#: a column with a cell longer than this holds text, which may be cut; shorter columns are kept whole
TEXT_CELL = 12
#: the narrowest a text column is cut to
MIN_TEXT = 10
ELLIPSIS = "…"

_width: int | None = DEFAULT_WIDTH


def set_width(width: int | None) -> None:
    """The width every following table and message fits (None: no limit, ``--wide``)."""
    global _width
    _width = width


def width() -> int | None:
    return _width


def cut(text: str, limit: int) -> str:
    """``text`` cut to ``limit`` characters, ending in an ellipsis when cut."""
    return text if len(text) <= limit else text[:max(limit - 1, 0)] + ELLIPSIS


def fitted_widths(rows: list[tuple], limit: int | None, keep: tuple = ()) -> list[int]:
    """Column widths of ``rows`` (the first is the header) so that a line fits ``limit`` characters with
    two spaces between columns, shrinking text columns only (never those whose heading is in ``keep``)."""
    widths = [max(len(str(row[i])) for row in rows) for i in range(len(rows[0]))]
    if limit is None:
        return widths
    text = {i for i in range(len(widths)) if rows[0][i] not in keep
            and any(len(str(row[i])) > TEXT_CELL for row in rows[1:])}
    floor = {i: max(MIN_TEXT, len(str(rows[0][i]))) for i in text}
    excess = sum(widths) + 2 * (len(widths) - 1) - limit
    while excess > 0:
        shrinkable = [i for i in text if widths[i] > floor[i]]
        if not shrinkable:
            break
        widest = max(shrinkable, key=lambda i: widths[i])
        others = [widths[i] for i in shrinkable if i != widest]
        # down to the next widest column (or the floor) in one go, at most what is still too much
        step = min(excess, widths[widest] - max(others + [floor[widest]]) or 1)
        widths[widest] -= step
        excess -= step
    return widths


def format_table(rows: list[tuple], limit: int | None | str = "default", keep: tuple = ("target",)) -> str:
    """Rows (the first the header) as aligned columns under a dashed line, fitting ``limit`` characters
    (default: the CLI's width, ``set_width``); columns headed by a name in ``keep`` are never cut."""
    limit = _width if limit == "default" else limit
    widths = fitted_widths(rows, limit, keep)
    lines = ["  ".join(cut(str(cell), w).ljust(w) for cell, w in zip(row, widths)).rstrip() for row in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def wrap(text: str, indent: str = "  ") -> str:
    """A long message wrapped to the CLI's width (whole: nothing cut), continuation lines indented."""
    if _width is None:
        return indent + text
    return textwrap.fill(text, width=_width, initial_indent=indent, subsequent_indent=indent + "  ",
                         break_long_words=False, break_on_hyphens=False)


#: a message in a progress line keeps at least this many characters before the name is cut
MIN_DETAIL = 24


def cut_middle(text: str, limit: int) -> str:
    """``text`` cut to ``limit`` characters in its middle (start and end kept: a target and a run name)."""
    if len(text) <= limit:
        return text
    head = max((limit - 1) // 2, 0)
    return text[:head] + ELLIPSIS + text[len(text) - max(limit - 1 - head, 0):]


def fit_line(before: str, name: str, after: str = "", detail: str = "", end: str = "") -> str:
    """``before + name + after + detail + end`` in the CLI's width (``--wide``: whole). The ``detail`` (a
    failure message) is cut first, to what the line leaves beside the whole name but not below ``MIN_DETAIL``;
    then the ``name`` (target, test case and run) is cut in its middle. ``before``, ``after`` and ``end`` (a
    counter, a state, a time) are kept."""
    if _width is None:
        return before + name + after + detail + end
    room = _width - len(before) - len(after) - len(end)
    if len(name) + len(detail) > room:
        keep = max(room - len(name), min(len(detail), MIN_DETAIL, room - MIN_TEXT))
        detail = cut(detail, keep) if keep > 0 else ""
    return before + cut_middle(name, max(room - len(detail), MIN_TEXT)) + after + detail + end
