"""The run record: what one run was and what came out of it, as ``run.json`` in its folder and in the store.

Its fields are declared once, in ``harness.config.record.RunRecord``, with their types; the record carries
``version`` (``RECORD_VERSION``) so that a reader knows which fields to expect, as asv's results carry an
api_version. What a run is before it runs is a ``RunSpec``.
``harness.execution.execute`` fills a record while it runs a run, ``harness.store.records`` stores it and imports it.

Records are strict JSON: a non-finite number (an engine's NaN timing, the thermo of a run that blew up) is
written as ``null``, and a record read back (``harness import``) is validated field by field; a record that
does not validate is one line naming the file and the field, and is not stored.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from datetime import datetime

from harness.config import check
from harness.config.record import (FAILURE_REASONS, RECORD_VERSION, SERIES_KINDS, STATES,  # noqa: F401 - read from here too
                                   RunRecord)
from harness.config.runconfig import DEFAULT_TIMEOUT
from harness.config.jsonfile import Problem
from harness.execution.workspace import segment_problem

RECORD_FILE = "run.json"
#: what a record file must name (the model gives the rest defaults, for records of older harnesses)
REQUIRED = ("machine", "target", "testcase", "run", "state")


@dataclass
class RunSpec:
    """One run as the planner (``harness.execution.planning.make_spec``) hands it to ``harness.execution.execute``: picklable, so a
    Dask worker gets it whole. ``folder`` is the run folder; ``source_folder`` and ``files`` (relative
    POSIX paths) what it is made of; ``timeout`` in s; ``environment`` the engine's variables on top of the
    process' own; ``dependency_folder`` the run folder whose ``post/`` is copied in; ``repeat`` how often the
    engine runs (``harness run --repeat``); ``profile`` the perf settings of a profiled run
    (``harness.execution.profiles.enable``)."""

    machine: str
    target: str
    target_definition: dict
    build: dict
    testcase: str
    run: str
    testcase_hash: str
    config: dict
    adapter: str
    thermo_columns: dict
    environment: dict
    workspace: str
    folder: str
    source_folder: str
    files: list
    timeout: float = DEFAULT_TIMEOUT
    command: list = field(default_factory=list)
    dependency_folder: str | None = None
    repeat: int = 1
    profile: dict | None = None

    def record(self) -> RunRecord:
        """A fresh record (not executed) of this run."""
        return RunRecord(machine=self.machine, target=self.target, testcase=self.testcase, run=self.run,
                         testcase_hash=self.testcase_hash, target_definition=self.target_definition,
                         build=self.build, config=self.config, folder=self.folder, command=list(self.command),
                         adapter=self.adapter)


def stepping_time_of(timing: dict) -> float | None:
    """The engine's own time stepping in s: the loop time its adapter reports as ``total`` (the bundled
    engine's timed loop, LIGGGHTS' and LAMMPS' summed "Loop time"); None when the engine reported none."""
    value = (timing or {}).get("total")
    return float(value) if isinstance(value, (int, float)) and value > 0 and math.isfinite(value) else None


def finite(value):
    """``value`` with every non-finite float replaced by None (strict JSON; PostgreSQL's jsonb refuses NaN)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite(v) for v in value]
    return value


def dumps(record: RunRecord) -> str:
    return json.dumps(finite(record.to_dict()), indent=1, allow_nan=False)


def _refuse_constant(name):
    raise ValueError(f"{name} is not valid JSON")


def validate(data) -> list[Problem]:
    """Problems of a record read from a file: the schema's (``harness.config.record``), then what it cannot
    say (names that are folders, dates, the failure reason of a failed run, series, the store's limits)."""
    if not isinstance(data, dict):
        return [Problem((), "a run record must be a JSON object")]
    problems = [Problem((key,), "required") for key in REQUIRED if key not in data]
    problems += check.validate(RunRecord, data)[1]
    if problems:
        return problems
    for key in ("machine", "target", "run"):
        problem = segment_problem(data[key])
        if problem:
            problems.append(Problem((key,), problem))
    if any(not part or part in (".", "..") for part in data["testcase"].split("/")):
        problems.append(Problem(("testcase",), f"{data['testcase'][:80]!r} is not a test case path"))
    if data["state"] == "failed" and not data.get("failure_reason"):
        problems.append(Problem(("failure_reason",), "required for a failed run"))
    if data["state"] != "failed" and data.get("failure_reason"):
        problems.append(Problem(("failure_reason",), f"a run in state {data['state']!r} has no failure reason"))
    for key in ("started", "finished"):
        if data.get(key) is not None:
            try:
                datetime.fromisoformat(data[key])
            except ValueError:
                problems.append(Problem((key,), f"not an ISO 8601 date and time: {data[key][:40]!r}"))
    if data.get("version", RECORD_VERSION) > RECORD_VERSION:
        problems.append(Problem(("version",), f"record version {data['version']} is newer than this harness "
                                              f"reads ({RECORD_VERSION})"))
    for i, series in enumerate(data.get("series", [])):
        problems += _series_problems(series, ("series", i))
    problems += _length_problems(data)
    nul = _nul_problem(data)
    if nul:  # PostgreSQL's text and jsonb cannot hold U+0000: no store takes it, so that both stores agree
        problems.append(nul)
    return problems


def _length_problems(data: dict) -> list[Problem]:
    """Texts longer than the store's columns hold (harness/store/models.py): PostgreSQL refuses them, SQLite would
    keep them; both stores refuse the record so that they agree."""
    try:
        # the store's models (Django) load once Django is set up (harness.store)
        from harness.store.models import Build, Run, Series, TestCase
    except Exception:  # noqa: BLE001 - without a configured store there is no column to compare with
        return []
    limits = [(("testcase",), data.get("testcase"), TestCase, "path")]
    build = data.get("build") if isinstance(data.get("build"), dict) else {}
    limits += [(("build", key), build.get(key), Build, key) for key in ("commit", "definition_hash", "revision")]
    limits.append((("testcase_hash",), data.get("testcase_hash"), Run, "testcase_hash"))
    for i, series in enumerate(data.get("series", [])):
        if isinstance(series, dict):
            limits += [(("series", i, key), series.get(key), Series, key) for key in ("name", "x_column")]
    problems = []
    for where, value, model, column in limits:
        limit = model._meta.get_field(column).max_length
        if isinstance(value, str) and limit and len(value) > limit:
            problems.append(Problem(where, f"{len(value)} characters, more than the store holds ({limit})"))
    return problems


def _nul_problem(value, where: tuple = ()) -> Problem | None:
    """The first string (value or key) holding U+0000 in ``value``, or None."""
    if isinstance(value, str):
        return Problem(where, "holds a NUL character (U+0000)") if "\x00" in value else None
    if isinstance(value, dict):
        for key, item in value.items():
            if "\x00" in key:
                return Problem(where, f"key {key[:40]!r} holds a NUL character (U+0000)")
            found = _nul_problem(item, (*where, key))
            if found:
                return found
    elif isinstance(value, list):
        for i, item in enumerate(value):
            found = _nul_problem(item, (*where, i))
            if found:
                return found
    return None


def null_values(record: RunRecord) -> str | None:
    """Where a record's series hold a null (a non-finite value written as null): ``"thermo.ke"``, or None."""
    for series in record.series:
        for name, values in (series.get("columns") or {}).items():
            if any(v is None for v in values):
                return f"{series.get('name')}.{name}"
    return None


def _series_problems(series, where: tuple) -> list[Problem]:
    if not isinstance(series, dict):
        return [Problem(where, "must be an object")]
    if series.get("kind") not in SERIES_KINDS:
        return [Problem((*where, "kind"), f"unknown kind {series.get('kind')!r} (known: {', '.join(SERIES_KINDS)})")]
    if not isinstance(series.get("name"), str) or not series["name"]:
        return [Problem((*where, "name"), "required (a string)")]
    columns = series.get("columns", {})
    if not isinstance(columns, dict):
        return [Problem((*where, "columns"), "must be an object of lists")]
    lengths = set()
    for name, values in columns.items():
        if not isinstance(values, list):
            return [Problem((*where, "columns", name), "must be a list")]
        if any(not isinstance(v, (int, float, str, type(None))) or isinstance(v, bool) for v in values):
            return [Problem((*where, "columns", name), "values must be numbers, strings or null")]
        lengths.add(len(values))
    if len(lengths) > 1:
        return [Problem((*where, "columns"), f"columns of different lengths {sorted(lengths)}")]
    return []


def loads(text: str) -> dict:
    """Parse a record's text; NaN and Infinity are refused (ValueError), as in every JSON input."""
    return json.loads(text, parse_constant=_refuse_constant)
