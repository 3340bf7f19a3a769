"""The run record: what one run was and what came out of it, as ``run.json`` in its folder and in the store.

Its fields are declared once, here (``RunRecord``), with their types; the record carries ``version``
(``RECORD_VERSION``) so that a reader knows which fields to expect, as asv's results carry an api_version.
``harness.execution.execute`` fills a record while it runs a run, ``harness.store.records`` stores it and imports it.

Records are strict JSON: a non-finite number (an engine's NaN timing, the thermo of a run that blew up) is
written as ``null``, and a record read back (``harness import``) is validated field by field; a record that
does not validate is one line naming the file and the field, and is not stored.
"""
from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field, fields
from datetime import datetime

#: version of the record layout; 1: before test case hashes; 2: ``testcase_hash`` and strict JSON
RECORD_VERSION = 2
RECORD_FILE = "run.json"

STATES = ("not_executed", "executed", "failed", "post_processed", "consistency_checked", "outdated")
FAILURE_REASONS = ("", "exit_code", "signal", "timeout", "non_finite", "missing_output", "error_line",
                   "interrupted", "post_script", "post_processing", "dependency", "config", "expectation",
                   "stability", "build_failed")
SERIES_KINDS = ("thermo", "plot", "vtk", "textfile")


@dataclass
class RunRecord:
    """One run. Times are ISO 8601 strings (UTC); ``wall_time`` in s (engine process, start-up and JIT
    compilation included); ``stepping_time`` in s (the engine's own loop time, ``stepping_time_of``);
    ``timing`` in s per category (pair, neigh, comm, modify, output, other, total, and what the engine
    adds); ``breakdown`` the same in the harness' sections with min/avg/max over ranks (``harness.analysis.breakdown``);
    ``profile`` the folded-stacks file of a profiled run, relative to its folder (``harness.execution.profiles``)."""

    machine: str
    target: str
    testcase: str
    run: str
    state: str = "not_executed"
    testcase_hash: str = ""
    target_definition: dict = field(default_factory=dict)
    build: dict = field(default_factory=dict)
    config: dict = field(default_factory=dict)
    folder: str = ""
    command: list = field(default_factory=list)
    adapter: str = ""
    failure_reason: str = ""
    failure_message: str = ""
    exit_code: int | None = None
    started: str | None = None
    finished: str | None = None
    wall_time: float | None = None
    stepping_time: float | None = None
    timing: dict = field(default_factory=dict)
    breakdown: dict = field(default_factory=dict)
    profile: str = ""
    warning_count: int = 0
    warnings: list = field(default_factory=list)
    series: list = field(default_factory=list)
    verdicts: list = field(default_factory=list)
    log_tail: str = ""
    stderr_tail: str = ""
    version: int = RECORD_VERSION

    @classmethod
    def from_spec(cls, spec: dict) -> "RunRecord":
        """A fresh record (not executed) of the run a run specification (``harness.execution.scheduler.make_spec``) names."""
        keys = ("machine", "target", "testcase", "run", "testcase_hash", "target_definition", "build", "config",
                "folder", "command", "adapter")
        return cls(**{key: spec[key] for key in keys if spec.get(key) is not None})

    def to_dict(self) -> dict:
        return asdict(self)


_TYPES = {f.name: f.type for f in fields(RunRecord)}
_REQUIRED = ("machine", "target", "testcase", "run", "state")
_KINDS = {"str": (str,), "dict": (dict,), "list": (list,), "int": (int,), "int | None": (int, type(None)),
          "str | None": (str, type(None)), "float | None": (int, float, type(None))}


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


def dumps(record: dict) -> str:
    return json.dumps(finite(record), indent=1, allow_nan=False)


def _refuse_constant(name):
    raise ValueError(f"{name} is not valid JSON")


def validate(data) -> list[str]:
    """Problems of a record read from a file: ``["$.state: unknown state 'passed'", ...]`` (empty: valid)."""
    if not isinstance(data, dict):
        return ["$: a run record must be a JSON object"]
    problems = [f"$.{key}: required" for key in _REQUIRED if key not in data]
    for key, value in data.items():
        kind = _TYPES.get(key)
        if kind is None:
            continue  # a newer harness may add fields; they are ignored, not lost in the file
        allowed = _KINDS[kind]
        if not isinstance(value, allowed) or (isinstance(value, bool) and bool not in allowed):
            problems.append(f"$.{key}: must be {kind.replace(' | None', ' or null')}, got {type(value).__name__}")
    if problems:
        return problems
    for key in ("machine", "target", "run"):
        from harness.execution.workspace import segment_problem

        problem = segment_problem(data[key])
        if problem:
            problems.append(f"$.{key}: {problem}")
    if any(not part or part in (".", "..") for part in data["testcase"].split("/")):
        problems.append(f"$.testcase: {data['testcase'][:80]!r} is not a test case path")
    if data["state"] not in STATES:
        problems.append(f"$.state: unknown state {data['state']!r} (known: {', '.join(STATES)})")
    if data.get("failure_reason", "") not in FAILURE_REASONS:
        problems.append(f"$.failure_reason: unknown reason {data['failure_reason']!r}")
    if data["state"] == "failed" and not data.get("failure_reason"):
        problems.append("$.failure_reason: required for a failed run")
    if data["state"] != "failed" and data.get("failure_reason"):
        problems.append(f"$.failure_reason: a run in state {data['state']!r} has no failure reason")
    for key in ("started", "finished"):
        if data.get(key) is not None:
            try:
                datetime.fromisoformat(data[key])
            except ValueError:
                problems.append(f"$.{key}: not an ISO 8601 date and time: {data[key][:40]!r}")
    if isinstance(data.get("version"), int) and data["version"] > RECORD_VERSION:
        problems.append(f"$.version: record version {data['version']} is newer than this harness reads "
                        f"({RECORD_VERSION})")
    for i, series in enumerate(data.get("series", [])):
        problems += _series_problems(series, f"$.series[{i}]")
    problems += _length_problems(data)
    nul = _nul_path(data, "$")
    if nul:  # PostgreSQL's text and jsonb cannot hold U+0000: no store takes it, so that both stores agree
        problems.append(f"{nul}: holds a NUL character (U+0000)")
    return problems


def _length_problems(data: dict) -> list[str]:
    """Texts longer than the store's columns hold (harness/store/models.py): PostgreSQL refuses them, SQLite would
    keep them; both stores refuse the record so that they agree."""
    try:
        from harness.store.models import Build, Series, TestCase
    except Exception:  # noqa: BLE001 - without a configured store there is no column to compare with
        return []
    limits = [("$.testcase", data.get("testcase"), TestCase, "path")]
    build = data.get("build") if isinstance(data.get("build"), dict) else {}
    limits += [(f"$.build.{key}", build.get(key), Build, key) for key in ("commit", "definition_hash", "revision")]
    from harness.store.models import Run

    limits.append(("$.testcase_hash", data.get("testcase_hash"), Run, "testcase_hash"))
    for i, series in enumerate(data.get("series", [])):
        if isinstance(series, dict):
            limits += [(f"$.series[{i}].{key}", series.get(key), Series, key) for key in ("name", "x_column")]
    problems = []
    for where, value, model, column in limits:
        limit = model._meta.get_field(column).max_length
        if isinstance(value, str) and limit and len(value) > limit:
            problems.append(f"{where}: {len(value)} characters, more than the store holds ({limit})")
    return problems


def _nul_path(value, where: str) -> str | None:
    """JSON path of the first string (value or key) holding U+0000 in ``value``, or None."""
    if isinstance(value, str):
        return where if "\x00" in value else None
    if isinstance(value, dict):
        for key, item in value.items():
            if "\x00" in key:
                return f"{where} key {key[:40]!r}"
            found = _nul_path(item, f"{where}.{key}")
            if found:
                return found
    elif isinstance(value, list):
        for i, item in enumerate(value):
            found = _nul_path(item, f"{where}[{i}]")
            if found:
                return found
    return None


def null_values(data: dict) -> str | None:
    """Where a record's series hold a null (a non-finite value written as null): ``"thermo.ke"``, or None."""
    for series in data.get("series", []):
        for name, values in (series.get("columns") or {}).items():
            if any(v is None for v in values):
                return f"{series.get('name')}.{name}"
    return None


def _series_problems(series, where: str) -> list[str]:
    if not isinstance(series, dict):
        return [f"{where}: must be an object"]
    if series.get("kind") not in SERIES_KINDS:
        return [f"{where}.kind: unknown kind {series.get('kind')!r} (known: {', '.join(SERIES_KINDS)})"]
    if not isinstance(series.get("name"), str) or not series["name"]:
        return [f"{where}.name: required (a string)"]
    columns = series.get("columns", {})
    if not isinstance(columns, dict):
        return [f"{where}.columns: must be an object of lists"]
    lengths = set()
    for name, values in columns.items():
        if not isinstance(values, list):
            return [f"{where}.columns.{name}: must be a list"]
        if any(not isinstance(v, (int, float, str, type(None))) or isinstance(v, bool) for v in values):
            return [f"{where}.columns.{name}: values must be numbers, strings or null"]
        lengths.add(len(values))
    if len(lengths) > 1:
        return [f"{where}.columns: columns of different lengths {sorted(lengths)}"]
    return []


def loads(text: str) -> dict:
    """Parse a record's text; NaN and Infinity are refused (ValueError), as in every JSON input."""
    return json.loads(text, parse_constant=_refuse_constant)
