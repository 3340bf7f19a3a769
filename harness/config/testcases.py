"""Test cases (thesis 4.3.1-4.3.3): folders with a run.config, found under a target's test case folders.

A run.config holds ``{"runs": [...]}``; each run configuration has

``name`` (required, unique), ``type`` (``serial`` | ``mpi`` with ``nprocs`` | ``mpi/custom`` with
``mpi_options``), ``script`` (a file in the folder, or ``{"dem": "scene.json", "liggghts": "in.scene"}``
chosen by the target's adapter; a run whose script names no file for the adapter is not run by that
target), ``variables`` (passed as ``-var NAME VALUE``), ``depends_on`` (a run of the same folder that runs
first; its ``post/`` is copied in), ``post_scripts`` (executables with a shebang, run in order in the run
folder), ``data`` (``series``, ``plots``, ``textfiles``, thesis listing 4.11), ``timeout`` (s, default
600), ``thermo_columns`` (mapping onto step, atoms, ke, rke), ``consistency`` (per quantity ``epsilon``
and/or ``floor``, same units as the quantity), ``vtk`` (``{"density": kg/m^3}`` for the kinetic energy
of dumps), and the acceptance keys ``expectations`` / ``stability`` (checked by ``harness.config.acceptance``).

A folder without run.config may still be a test case if the adapter supplies a default configuration
(``EngineAdapter.default_run_config``, e.g. one serial run per LIGGGHTS ``in.*`` script).

Names become folders of the workspace, so run names and test case folder names must be safe single path
segments (``harness.execution.workspace.segment_problem``); folders with a reserved name (post, restart, meshes,
scripts, __pycache__) are parts of a test case and never test cases themselves (a run.config in one is
reported, not silently ignored). Validation never raises for a broken entry: it carries its problems, each
``FILE: $.runs[i].field: what is wrong``, and is recorded as failed (reason config) while the rest runs.
"""
from __future__ import annotations

import fnmatch
import hashlib
import json
import os
import re
import shlex
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath

from harness.config import gitrepo
from harness.adapters.base import UserError
from harness.config.jsonfile import Problems, expect_type, has_non_finite, json_path, load_json, non_finite_problems
from harness.config.targets import WORKING_TREE, TargetDefinition
from harness.execution.workspace import RESERVED_NAMES, segment_problem, workspace

RUN_CONFIG = "run.config"
RUN_TYPES = ("serial", "mpi", "mpi/custom")
DEFAULT_TIMEOUT = 600.0
#: folders of a test case that never hold a nested test case (thesis 4.3.1)
NOT_TESTCASES = RESERVED_NAMES
#: never part of a test case's content: its output folder (but post/restart/), records, version control
_NOT_CONTENT = {"post", "run.json", ".git", "__pycache__"}
RUN_KEYS = {"name", "type", "nprocs", "mpi_options", "script", "variables", "depends_on", "post_scripts", "data",
            "timeout", "thermo_columns", "consistency", "vtk", "expectations", "stability", "description",
            "sweep", "sweep_point", "scaling", "scaling_point", "profile"}
#: a pseudo run name that carries a broken run.config into the store and the JUnit report
CONFIG_RUN = "run.config"


@dataclass
class RunEntry:
    """One run configuration of a test case, validated for one adapter."""

    name: str
    config: dict
    script: str | None = None
    problems: list[str] = field(default_factory=list)

    @property
    def depends_on(self) -> str | None:
        return self.config.get("depends_on")

    @property
    def timeout(self) -> float:
        return float(self.config.get("timeout", DEFAULT_TIMEOUT))


@dataclass
class TestCaseSpec:
    """A test case folder and its run configurations (invalid ones carry their problems)."""

    path: str          # identity: path relative to the test case root, e.g. "testcases/settling"
    folder: Path       # where its files are (exported or working tree)
    runs: list[RunEntry]
    generated: bool = False   # run.config supplied by the adapter

    def run(self, name: str) -> RunEntry | None:
        return next((entry for entry in self.runs if entry.name == name), None)

    def files(self) -> list[str]:
        """The files a run folder gets (relative POSIX paths, sorted); see ``testcase_files``."""
        if self._files is None:
            self._files = testcase_files(self.folder)
        return self._files

    def content_hash(self, name: str) -> str:
        """sha256 (hex) of run ``name`` as it runs: its run.config entry (variables included), the bytes of
        every file copied into its run folder, and the content hash of the run it depends on (whose
        ``post/`` it receives). A change to any of them makes it another run (harness.execution.scheduler)."""
        if name not in self._hashes:
            entry = self.run(name)
            digest = hashlib.sha256()
            digest.update(json.dumps(entry.config if entry else {}, sort_keys=True, default=str).encode())
            digest.update(self._files_digest().encode())
            dependency = entry.depends_on if entry else None
            self._hashes[name] = ""  # a dependency cycle (reported by validation) must not recurse
            if isinstance(dependency, str) and self.run(dependency) is not None:
                digest.update(self.content_hash(dependency).encode())
            self._hashes[name] = digest.hexdigest()
        return self._hashes[name]

    def _files_digest(self) -> str:
        if self._digest is None:
            digest = hashlib.sha256()
            for rel in self.files():
                path = self.folder / rel
                digest.update(rel.encode() + b"\0")
                if path.is_symlink():
                    digest.update(b"link:" + os.readlink(path).encode())
                else:
                    digest.update(hashlib.sha256(path.read_bytes()).digest())
            self._digest = digest.hexdigest()
        return self._digest

    _files: list | None = field(default=None, repr=False, compare=False)
    _digest: str | None = field(default=None, repr=False, compare=False)
    _hashes: dict = field(default_factory=dict, repr=False, compare=False)


def testcase_files(folder: Path) -> list[str]:
    """Files of the test case in ``folder``: everything below it except ``post/`` (but ``post/restart/``,
    restart files the case ships, thesis 4.3.1), ``run.json``, ``.git``, ``__pycache__`` and the folders
    of nested test cases (a subfolder with its own run.config is another test case)."""
    folder = Path(folder)
    found = []
    for current, dirs, files in os.walk(folder):
        current = Path(current)
        rel_dir = current.relative_to(folder)
        keep = []
        for d in sorted(dirs):
            path = current / d
            if d in _NOT_CONTENT and not (rel_dir == Path("post") and d == "restart"):
                if not (current == folder and d == "post" and (path / "restart").is_dir()):
                    continue
            if (path / RUN_CONFIG).is_file() and not path.is_symlink():
                continue
            if path.is_symlink():
                files.append(d)  # a linked folder is copied as the link
                continue
            keep.append(d)
        dirs[:] = keep
        in_post = rel_dir.parts[:1] == ("post",)
        for name in sorted(files):
            rel = (rel_dir / name).as_posix()
            if in_post and not rel.startswith("post/restart/"):
                continue
            if name in _NOT_CONTENT:
                continue
            found.append(rel)
    return sorted(found)


def _validate_data(problems: Problems, data, where: list) -> None:
    if not expect_type(problems, json_path(*where), data, dict, "an object"):
        return
    for key in sorted(set(data) - {"series", "plots", "textfiles"}):
        problems.add(json_path(*where, key), "unknown field (known: series, plots, textfiles)")
    series_names = set()
    series = data.get("series", [])
    if expect_type(problems, json_path(*where, "series"), series, list, "a list"):
        for i, item in enumerate(series):
            at = [*where, "series", i]
            if not expect_type(problems, json_path(*at), item, dict, "an object"):
                continue
            for key in ("name", "file"):
                if key not in item:
                    problems.add(json_path(*at, key), "required")
                else:
                    expect_type(problems, json_path(*at, key), item[key], str, "a string")
            if "columns" in item and expect_type(problems, json_path(*at, "columns"), item["columns"], list,
                                                 "a list of column names"):
                for j, column in enumerate(item["columns"]):
                    expect_type(problems, json_path(*at, "columns", j), column, str, "a string")
            if isinstance(item.get("name"), str):
                series_names.add(item["name"])
    plots = data.get("plots", [])
    if expect_type(problems, json_path(*where, "plots"), plots, list, "a list"):
        for i, item in enumerate(plots):
            at = [*where, "plots", i]
            if not expect_type(problems, json_path(*at), item, dict, "an object"):
                continue
            for key in ("name", "xdata", "ydata"):
                if key not in item:
                    problems.add(json_path(*at, key), "required")
            refs = [item.get("xdata")] + (item.get("ydata") if isinstance(item.get("ydata"), list)
                                          else [item.get("ydata")])
            for ref in refs:
                if ref is None:
                    continue
                if not isinstance(ref, str) or "." not in ref:
                    problems.add(json_path(*at), f"data reference {ref!r} must be 'series.column'")
                elif ref.split(".", 1)[0] not in series_names:
                    problems.add(json_path(*at), f"data reference {ref!r} names no declared series")
    textfiles = data.get("textfiles", [])
    if expect_type(problems, json_path(*where, "textfiles"), textfiles, list, "a list"):
        for i, item in enumerate(textfiles):
            at = [*where, "textfiles", i]
            if isinstance(item, dict):
                if not isinstance(item.get("file"), str):
                    problems.add(json_path(*at, "file"), "required (a string)")
                for key in ("rtol", "atol"):
                    if key in item:
                        expect_type(problems, json_path(*at, key), item[key], (int, float), "a number")
            else:
                expect_type(problems, json_path(*at), item, str, "a file name or an object with 'file'")


def _where_in_entry(at: list, message: str) -> tuple[str, str]:
    """``"expectations[1].at: must be ..."`` (a path inside the entry, from harness.config.acceptance and
    harness.config.sweep) -> (``$.runs[i].expectations[1].at``, ``must be ...``)."""
    inner, sep, what = message.partition(": ")
    if not sep or " " in inner:
        return json_path(*at), message
    return json_path(*at) + ("" if inner.startswith("[") else ".") + inner, what


def _file_in_testcase_problem(name: str) -> str | None:
    """A script or post script runs in the run folder, which holds the test case's files: it must be one
    of them (its bytes are part of the content hash), not a path outside."""
    path = PurePosixPath(name)
    if not name.strip() or path.is_absolute() or ".." in path.parts:
        return f"{name!r} must be a file of the test case folder (a relative path without '..')"
    return None


def _validate_entry(problems: Problems, entry: dict, i: int, folder: Path, adapter_name: str) -> str | None:
    """Validate one run configuration; returns the script for ``adapter_name`` (None: not for it)."""
    at = ["runs", i]
    for key in sorted(set(entry) - RUN_KEYS):
        problems.add(json_path(*at, key), f"unknown field (known: {', '.join(sorted(RUN_KEYS))})")
    if "name" not in entry:
        problems.add(json_path(*at, "name"), "required")
    elif expect_type(problems, json_path(*at, "name"), entry["name"], str, "a string"):
        # the name becomes the run folder's name: one safe path segment, never '..', '/x' or ''
        problem = segment_problem(entry["name"])
        if problem:
            problems.add(json_path(*at, "name"), f"run name {problem}")
        elif entry["name"] == CONFIG_RUN:
            problems.add(json_path(*at, "name"), f"{CONFIG_RUN!r} is the name under which a broken run.config "
                         "is reported; choose another")
    if "description" in entry:
        expect_type(problems, json_path(*at, "description"), entry["description"], str, "a string")
    run_type = entry.get("type", "serial")
    if run_type not in RUN_TYPES:
        problems.add(json_path(*at, "type"), f"unknown run type {run_type!r} (known: {', '.join(RUN_TYPES)})")
    if run_type == "mpi":
        if "nprocs" not in entry:
            problems.add(json_path(*at, "nprocs"), "required for type mpi")
        elif expect_type(problems, json_path(*at, "nprocs"), entry["nprocs"], int, "an integer") \
                and entry["nprocs"] < 1:
            problems.add(json_path(*at, "nprocs"), "must be at least 1")
    if run_type == "mpi/custom":
        options = entry.get("mpi_options")
        if options is None:
            problems.add(json_path(*at, "mpi_options"), "required for type mpi/custom")
        elif isinstance(options, list):
            for j, option in enumerate(options):
                expect_type(problems, json_path(*at, "mpi_options", j), option, str, "a string")
        elif expect_type(problems, json_path(*at, "mpi_options"), options, str, "a string or a list of strings"):
            try:
                shlex.split(options)  # what the launcher command line is made of (harness.execution.scheduler.mpi_prefix)
            except ValueError as exc:
                problems.add(json_path(*at, "mpi_options"), f"cannot be split into arguments ({exc})")
    for key in ("variables", "thermo_columns", "consistency", "vtk"):
        if key in entry:
            expect_type(problems, json_path(*at, key), entry[key], dict, "an object")
    if isinstance(entry.get("variables"), dict):
        for name, value in entry["variables"].items():
            expect_type(problems, json_path(*at, "variables", name), value, (str, int, float), "a string or number")
    if isinstance(entry.get("thermo_columns"), dict):
        for name, value in entry["thermo_columns"].items():
            expect_type(problems, json_path(*at, "thermo_columns", name), value, str, "a column name (string)")
    if isinstance(entry.get("vtk"), dict):
        for key, value in entry["vtk"].items():
            if key != "density":
                problems.add(json_path(*at, "vtk", key), "unknown field (known: density)")
            elif expect_type(problems, json_path(*at, "vtk", key), value, (int, float), "a number (kg/m^3)") \
                    and value <= 0:
                problems.add(json_path(*at, "vtk", key), "must be positive")
    if isinstance(entry.get("consistency"), dict):
        for quantity, setting in entry["consistency"].items():
            where = json_path(*at, "consistency", quantity)
            if expect_type(problems, where, setting, dict, "an object with epsilon and/or floor"):
                for key, value in setting.items():
                    if key == "ignore":
                        expect_type(problems, f"{where}.{key}", value, bool, "true or false")
                    elif key not in ("epsilon", "floor", "rtol", "atol"):
                        problems.add(f"{where}.{key}", "unknown field (known: epsilon, floor, rtol, atol, ignore)")
                    elif expect_type(problems, f"{where}.{key}", value, (int, float), "a number") and value < 0:
                        problems.add(f"{where}.{key}", "must not be negative")
    if "timeout" in entry and expect_type(problems, json_path(*at, "timeout"), entry["timeout"], (int, float),
                                          "a number of seconds") and entry["timeout"] <= 0:
        problems.add(json_path(*at, "timeout"), "must be positive")
    if "depends_on" in entry:
        expect_type(problems, json_path(*at, "depends_on"), entry["depends_on"], str, "a run name")
    post_scripts = entry.get("post_scripts", [])
    if expect_type(problems, json_path(*at, "post_scripts"), post_scripts, list, "a list of file names"):
        for j, script in enumerate(post_scripts):
            if not expect_type(problems, json_path(*at, "post_scripts", j), script, str, "a file name"):
                continue
            problem = _file_in_testcase_problem(script)
            if problem:
                problems.add(json_path(*at, "post_scripts", j), problem)
            elif not (folder / script).is_file():
                problems.add(json_path(*at, "post_scripts", j), f"post script {script!r} not found in {folder}")
    if "data" in entry:
        _validate_data(problems, entry["data"], [*at, "data"])
    # harness.config.acceptance and harness.config.sweep name paths inside the entry; a NaN there is reported already
    already = {message[len(f"{problems.path}: "):].partition(": ")[0] for message in problems.messages}
    from harness.config import acceptance, sweep
    from harness.execution import profiles
    from harness.analysis import scaling

    inner = (acceptance.validate(entry) if "expectations" in entry or "stability" in entry else []) \
        + sweep.validate(entry) + scaling.validate(entry) \
        + (profiles.validate(entry["profile"]) if "profile" in entry else [])
    for message in inner:
        where, what = _where_in_entry(at, message)
        if where not in already:
            problems.add(where, what)

    script = entry.get("script")
    if script is None:
        problems.add(json_path(*at, "script"), "required")
        return None
    if isinstance(script, dict):
        for key, value in script.items():
            expect_type(problems, json_path(*at, "script", key), value, str, "a file name")
        script = script.get(adapter_name)
        if script is None:
            return None
        where = json_path(*at, "script", adapter_name)
    else:
        where = json_path(*at, "script")
        if not expect_type(problems, where, script, str, "a file name or an object per engine adapter"):
            return None
        from harness.adapters import get_adapter

        accepts = getattr(get_adapter(adapter_name), "accepts_script", None)
        if accepts is not None and not accepts(script):
            return None  # a plain script in another code's input language: not a run for this engine
    if isinstance(script, str):
        problem = _file_in_testcase_problem(script)
        if problem:
            problems.add(where, problem)
        elif not (folder / script).is_file():
            problems.add(where, f"script {script!r} not found in {folder}")
    return script


def _dependency_problems(path: Path, runs: list[tuple[int, dict]]) -> dict[int, list[str]]:
    """Problems of ``depends_on`` per position in ``runs`` (pairs of the index in the file and the entry):
    an unknown run, or a cycle (reported for every run on it)."""
    found: dict[int, list[str]] = {}
    names = [entry.get("name") for _i, entry in runs if isinstance(entry, dict)]
    graph = {}
    for k, (i, entry) in enumerate(runs):
        if not isinstance(entry, dict):
            continue
        dep = entry.get("depends_on")
        if isinstance(entry.get("name"), str):  # a name of another type is reported by _validate_entry
            graph.setdefault(entry["name"], dep)
        if isinstance(dep, str) and dep not in names:
            problems = Problems(path)
            problems.add(json_path("runs", i, "depends_on"),
                         f"unknown run {dep!r} (runs here: {', '.join(map(str, names))})")
            found.setdefault(k, []).extend(problems.messages)
    for k, (i, entry) in enumerate(runs):
        if not isinstance(entry, dict) or not isinstance(entry.get("name"), str):
            continue
        start = entry["name"]
        seen, node = [], start
        while node in graph and isinstance(graph[node], str):
            if node in seen:
                if node == start:
                    problems = Problems(path)
                    cycle = seen + [node]
                    problems.add(json_path("runs", i, "depends_on"),
                                 "dependency cycle: " + " -> ".join(map(str, cycle)))
                    found.setdefault(k, []).extend(problems.messages)
                break
            seen.append(node)
            node = graph[node]
    return found


def _without_broken_fields(entry: dict, problems: list[str], i: int) -> dict:
    """The entry without the fields its problems name. A broken entry is only recorded (reason config),
    never run; what is recorded must still be plain JSON of the expected shapes (no NaN for the store,
    no list where the planner reads an object)."""
    prefix = json_path("runs", i) + "."
    bad = set()
    for message in problems:
        _file, sep, rest = message.partition(": " + prefix)
        if sep:
            bad.add(re.split(r"[.\[:]", rest, maxsplit=1)[0])
    return {key: value for key, value in entry.items() if key not in bad and not has_non_finite(value)}


def _parallelism(adapter_name: str) -> str:
    """How the adapter's code uses more cores (``EngineAdapter.parallelism``); "mpi" when it cannot be told."""
    from harness.adapters import get_adapter

    try:
        return get_adapter(adapter_name).parallelism
    except Exception:  # noqa: BLE001 - an unknown adapter is reported where the target is read
        return "mpi"


def parse_run_config(data, path: Path, adapter_name: str) -> tuple[list[RunEntry], list[str]]:
    """Validate a run.config for one adapter: the run entries (with their own problems) and the problems
    of the file (file-level ones and those between entries: duplicate names, dependencies).

    A problem in one entry marks that entry invalid (it is recorded as failed, reason config); the others
    stay runnable. Problems of the file as a whole (not an object, no runs list, an entry that is no
    object, an unknown top-level field) that concern no run are carried by a pseudo run named
    ``run.config`` (``CONFIG_RUN``), so they are reported and recorded while the valid runs still run.
    JSON paths count entries as written in the file, also after a sweep expanded into several runs.
    """
    folder = path.parent
    file_problems = Problems(path)
    if not isinstance(data, dict):
        non_finite_problems(file_problems, data)
        file_problems.add("$", "a run.config must be a JSON object with a 'runs' list")
        return _with_config_run([], file_problems.messages), file_problems.messages
    for key in sorted(set(data) - {"runs", "description"}):
        file_problems.add(json_path(key), "unknown field (known: runs, description)")
    non_finite_problems(file_problems, {k: v for k, v in data.items() if k != "runs"})
    if "description" in data:
        expect_type(file_problems, json_path("description"), data["description"], str, "a string")
    runs = data.get("runs")
    if runs is None:
        file_problems.add(json_path("runs"), "required")
        return _with_config_run([], file_problems.messages), file_problems.messages
    if not expect_type(file_problems, json_path("runs"), runs, list, "a list of run configurations"):
        non_finite_problems(file_problems, runs, "runs")
        return _with_config_run([], file_problems.messages), file_problems.messages
    # a valid sweep block becomes one ordinary run per value (harness.config.sweep); an invalid one stays to be
    # reported as one entry. Each item keeps the index of its entry in the file and the entry's NaN problems.
    from harness.analysis import scaling
    from harness.config import sweep

    parallelism = _parallelism(adapter_name)
    items: list[tuple[int, object, list[str]]] = []
    for i, entry in enumerate(runs):
        non_finite = Problems(path)
        non_finite_problems(non_finite, entry, "runs", i)
        expandable = (isinstance(entry, dict) and not non_finite and isinstance(entry.get("name"), str)
                      and segment_problem(entry["name"]) is None and isinstance(entry.get("variables", {}), dict)
                      and not sweep.validate(entry) and not scaling.validate(entry))
        for point in sweep.expand(entry) if expandable else [entry]:
            for scaled in scaling.expand(point, parallelism) if expandable else [point]:
                items.append((i, scaled, non_finite.messages))
    between: dict[int, list[str]] = {}   # problems between entries, by position in items
    names = [entry.get("name") for _i, entry, _p in items if isinstance(entry, dict)]
    for k, (i, entry, _p) in enumerate(items):
        name = entry.get("name") if isinstance(entry, dict) else None
        if isinstance(name, str) and names.count(name) > 1:
            problems = Problems(path)
            problems.add(json_path("runs", i, "name"), f"run name {name!r} is used more than once")
            between.setdefault(k, []).extend(problems.messages)
    for k, messages in _dependency_problems(path, [(i, entry) for i, entry, _p in items]).items():
        between.setdefault(k, []).extend(messages)
    entries = []
    unattached = list(file_problems.messages)
    for k, (i, entry, non_finite) in enumerate(items):
        problems = Problems(path)
        problems.messages.extend(non_finite)
        if not isinstance(entry, dict):
            if not non_finite:
                expect_type(problems, json_path("runs", i), entry, dict, "a run configuration object")
            unattached.extend(problems.messages)
            continue
        script = _validate_entry(problems, entry, i, folder, adapter_name)
        problems.messages.extend(between.get(k, []))
        valid_name = isinstance(entry.get("name"), str) and not any(
            f": {json_path('runs', i, 'name')}: " in m for m in problems.messages
            if "used more than once" not in m)
        name = entry["name"] if valid_name else f"runs[{i}]"
        if script is None and not problems and "script" in entry:
            continue  # this run is written for another engine
        config = _without_broken_fields(entry, problems.messages, i) if problems else entry
        entries.append(RunEntry(name=name, config=config, script=script, problems=problems.messages))
    reported = file_problems.messages + [m for messages in between.values() for m in messages]
    reported += [m for m in unattached if m not in reported]
    return _with_config_run(entries, unattached), reported


def _with_config_run(entries: list[RunEntry], unattached: list[str]) -> list[RunEntry]:
    """``entries`` and, when some problems concern no run, the pseudo run ``run.config`` carrying them."""
    if unattached:
        entries = entries + [RunEntry(CONFIG_RUN, {}, problems=list(unattached))]
    return entries


def load_testcase(folder: Path, path: str, adapter) -> TestCaseSpec | None:
    """The test case in ``folder`` (identity ``path``), or None if the folder is not a test case."""
    config_file = folder / RUN_CONFIG
    generated = False
    if config_file.is_file():
        try:
            data = load_json(config_file, strict=False)
        except UserError as exc:
            return TestCaseSpec(path, folder, [RunEntry(CONFIG_RUN, {}, problems=[str(exc)])])
    else:
        data = adapter.default_run_config(folder)
        if data is None:
            return None
        generated = True
    entries, _problems = parse_run_config(data, config_file, adapter.name)
    return TestCaseSpec(path, folder, entries, generated)


def _holds_testcase(folder: Path, adapter) -> bool:
    """Whether ``folder`` or a folder below it would be a test case."""
    for current, dirs, files in os.walk(folder):
        dirs[:] = [d for d in dirs if not d.startswith(".")]
        if RUN_CONFIG in files or adapter.default_run_config(Path(current)) is not None:
            return True
    return False


def _walk(root: Path, base: Path, prefix: str, adapter) -> tuple[list[TestCaseSpec], list[str]]:
    """The test cases below ``root`` and the problems of folders skipped.

    Skipped: folders starting with '.' (silently); folders with a reserved name (post, restart, meshes,
    scripts, __pycache__: a test case's own parts, never a test case) - reported when one holds a
    run.config the user may expect to run; folders whose name is not a safe path segment (it would name a
    folder of the workspace) - reported, with everything below them, when they hold a test case.
    """
    found, problems = [], []
    if not root.is_dir():
        return found, problems
    for current, dirs, _files in os.walk(root):
        current = Path(current)
        keep = []
        for d in sorted(dirs):
            if d.startswith("."):
                continue
            if d in NOT_TESTCASES:
                if (current / d / RUN_CONFIG).is_file():
                    problems.append(f"{current / d / RUN_CONFIG}: ignored: {d!r} is a reserved folder name "
                                    f"({', '.join(sorted(NOT_TESTCASES))}) and never a test case; rename the "
                                    "folder to run it")
                continue
            problem = segment_problem(d)
            if problem:
                if _holds_testcase(current / d, adapter):
                    problems.append(f"{current / d}: skipped: test case folder name {problem}")
                continue
            keep.append(d)
        dirs[:] = keep
        rel = current.relative_to(base).as_posix()
        spec = load_testcase(current, f"{prefix}{rel}" if prefix else rel, adapter)
        if spec is not None:
            found.append(spec)
    return found, problems


def testcase_root(target: TargetDefinition, working_tree: bool = False) -> Path:
    """The folder the target's test case folders are relative to: the working tree or an export."""
    if working_tree or target.testcases_revision == WORKING_TREE:
        repo = gitrepo.open_repository(target.testcases_repository)
        if repo.bare:
            raise UserError(f"{target.path}: $.testcases_revision: {WORKING_TREE!r} needs a local checkout, "
                            f"{target.testcases_repository} is bare")
        return Path(repo.working_tree_dir)
    repo = gitrepo.open_repository(target.testcases_repository)
    commit = gitrepo.resolve(repo, target.testcases_revision).hexsha
    # one export per repository, commit and set of folders (another target may list other folders)
    key = hashlib.sha1(json.dumps([str(target.testcases_repository), sorted(target.testcases)]).encode())
    ws = workspace()
    root = ws.builds / "testcases" / key.hexdigest()[:12] / commit
    if (root / ".done").is_file():
        return root
    with ws.lock(f"testcases-{key.hexdigest()[:12]}-{commit}"):  # another process may export it right now
        if not (root / ".done").is_file():
            ws.fresh_folder(root)
            for folder in target.testcases:
                if not Path(folder).is_absolute():
                    try:
                        gitrepo.export(repo, commit, folder, root)
                    except UserError:
                        pass  # reported by discover() as a missing folder
            (root / ".done").write_text(commit)
    return root


def discover(target: TargetDefinition, adapter, working_tree: bool = False) -> tuple[list[TestCaseSpec], list[str]]:
    """The test cases of a target and problems (missing test case folders, folders skipped by ``_walk``)."""
    root = None
    specs, problems = [], []
    for folder in target.testcases:
        path = Path(folder).expanduser()
        if path.is_absolute():
            base, prefix = path, path.name + "/"
        else:
            root = root or testcase_root(target, working_tree)
            base, prefix, path = root, "", root / folder
        if not path.is_dir():
            problems.append(f"{target.path}: $.testcases: folder {folder!r} does not exist"
                            + ("" if Path(folder).is_absolute() else f" at {target.testcases_revision}"))
            continue
        found, skipped = _walk(path, base, prefix, adapter)
        problems.extend(skipped)
        for spec in found:
            if prefix and spec.path.endswith("/."):
                spec.path = spec.path[:-2]
            specs.append(spec)
    return specs, problems


def matches(pattern: str | None, testcase_path: str, run_name: str) -> bool:
    """``-k``: a glob when it holds ``*?[``, else a substring, matched against ``testcase/run``."""
    if not pattern:
        return True
    key = f"{testcase_path}/{run_name}"
    if any(c in pattern for c in "*?["):
        return fnmatch.fnmatchcase(key, pattern)
    return pattern in key
