"""Test cases (thesis 4.3.1-4.3.3): folders with a run.config, found under a target's test case folders.

A run.config holds ``{"runs": [...]}``; the fields of a run configuration (name, type, script, variables,
depends_on, post_scripts, data, timeout, thermo_columns, consistency, vtk, expectations, stability, sweep,
scaling, profile) are declared once in ``harness.config.runconfig`` (docs/run-config.md is generated from
it). Here each entry is checked against that schema and what it cannot say (a script or post script that
is a file of the folder, the fields a run type needs, plot references, dependencies and duplicate names
between entries), and a sweep or scaling study expands into ordinary runs.

A folder without run.config may still be a test case if the adapter supplies a default configuration
(``EngineAdapter.default_run_config``, e.g. one serial run per LIGGGHTS ``in.*`` script).

Names become folders of the workspace, so run names and test case folder names must be safe single path
segments (``harness.execution.workspace.segment_problem``); folders with a reserved name (post, restart, meshes,
scripts, __pycache__) are parts of a test case and never test cases themselves (a run.config in one is
reported, not silently ignored). Validation never raises for a broken entry: it carries its problems
(``harness.config.jsonfile.Problem``: JSON path and message, shown as ``FILE: $.runs[i].field: what is wrong``),
and is recorded as failed (reason config) while the rest runs.
"""
from __future__ import annotations

import fnmatch
import hashlib
import json
import os
import shlex
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath

from harness.config import acceptance

from harness.config import gitrepo

from harness.analysis import scaling

from harness.config import sweep
from harness.adapters import get_adapter
from harness.adapters.base import UserError
from harness.config import check
from harness.config.runconfig import DEFAULT_TIMEOUT, RunConfig, RunConfigEntry
from harness.config.jsonfile import JsonFileError, Problem, Problems, has_non_finite, load_json, non_finite_problems
from harness.config.targets import WORKING_TREE, TargetDefinition
from harness.execution.workspace import RESERVED_NAMES, segment_problem, workspace

RUN_CONFIG = "run.config"
#: folders of a test case that never hold a nested test case (thesis 4.3.1)
NOT_TESTCASES = RESERVED_NAMES
#: never part of a test case's content: its output folder (but post/restart/), records, version control
_NOT_CONTENT = {"post", "run.json", ".git", "__pycache__"}
#: a pseudo run name that carries a broken run.config into the store and the JUnit report
CONFIG_RUN = "run.config"


@dataclass
class RunEntry:
    """One run configuration of a test case, validated for one adapter: ``config`` as written (what is
    hashed and stored), ``spec`` the same typed (``harness.config.runconfig``; None when it has problems),
    ``found`` its problems in ``file``."""

    name: str
    config: dict
    script: str | None = None
    found: list[Problem] = field(default_factory=list)
    file: Path | None = None
    spec: RunConfigEntry | None = None

    @property
    def problems(self) -> list[str]:
        """The problems as the lines a user reads (``FILE: $.runs[1].timeout: must be positive``)."""
        return [problem.line(self.file) for problem in self.found]

    @property
    def depends_on(self) -> str | None:
        return self.spec.depends_on if self.spec else self.config.get("depends_on")

    @property
    def timeout(self) -> float:
        return self.spec.timeout if self.spec else float(self.config.get("timeout", DEFAULT_TIMEOUT))


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


def _file_in_testcase_problem(name: str) -> str | None:
    """A script or post script runs in the run folder, which holds the test case's files: it must be one
    of them (its bytes are part of the content hash), not a path outside."""
    path = PurePosixPath(name)
    if not name.strip() or path.is_absolute() or ".." in path.parts:
        return f"{name!r} must be a file of the test case folder (a relative path without '..')"
    return None


def _entry_problems(entry: dict, at: tuple, folder: Path, adapter_name: str):
    """The problems of one run configuration (the schema's, then what it cannot say), the script for
    ``adapter_name`` (None: not for it) and the typed entry (None when it has problems)."""
    typed, found = check.validate(RunConfigEntry, entry, at)
    found += _name_problems(entry.get("name"), at) + _launch_problems(entry, at)
    found += _post_script_problems(entry.get("post_scripts"), at, folder)
    found += _plot_problems(entry.get("data"), at)
    found += acceptance.problems(entry, at) + sweep.problems(entry, at) + scaling.problems(entry, at)
    script, script_problems = _script(entry, at, folder, adapter_name)
    return found + script_problems, script, typed


def _name_problems(name, at: tuple) -> list[Problem]:
    """The name becomes the run folder's name: one safe path segment, never '..', '/x' or ''."""
    if not isinstance(name, str):
        return []
    problem = segment_problem(name)
    if problem:
        return [Problem((*at, "name"), f"run name {problem}")]
    if name == CONFIG_RUN:
        return [Problem((*at, "name"), f"{CONFIG_RUN!r} is the name under which a broken run.config is "
                                       "reported; choose another")]
    return []


def _launch_problems(entry: dict, at: tuple) -> list[Problem]:
    """What a run type needs: ``nprocs`` for mpi, ``mpi_options`` a launcher can take for mpi/custom."""
    run_type, options = entry.get("type"), entry.get("mpi_options")
    if run_type == "mpi" and "nprocs" not in entry:
        return [Problem((*at, "nprocs"), "required for type mpi")]
    if run_type == "mpi/custom" and options is None:
        return [Problem((*at, "mpi_options"), "required for type mpi/custom")]
    if run_type == "mpi/custom" and isinstance(options, str):
        try:
            shlex.split(options)  # what the launcher command line is made of (harness.execution.planning.mpi_prefix)
        except ValueError as exc:
            return [Problem((*at, "mpi_options"), f"cannot be split into arguments ({exc})")]
    return []


def _post_script_problems(scripts, at: tuple, folder: Path) -> list[Problem]:
    found = []
    for j, script in enumerate(scripts if isinstance(scripts, list) else []):
        if not isinstance(script, str):
            continue
        problem = _file_in_testcase_problem(script)
        if problem or not (folder / script).is_file():
            found.append(Problem((*at, "post_scripts", j), problem or f"post script {script!r} not found in {folder}"))
    return found


def _plot_problems(data, at: tuple) -> list[Problem]:
    """Each plot's ``xdata`` and ``ydata`` name a column of a declared series (``series.column``)."""
    if not isinstance(data, dict):
        return []
    series = data.get("series") if isinstance(data.get("series"), list) else []
    names = {item["name"] for item in series if isinstance(item, dict) and isinstance(item.get("name"), str)}
    found = []
    plots = data.get("plots") if isinstance(data.get("plots"), list) else []
    for i, item in enumerate(plots):
        if not isinstance(item, dict):
            continue
        ydata = item.get("ydata")
        for ref in [item.get("xdata")] + (ydata if isinstance(ydata, list) else [ydata]):
            if ref is None:
                continue
            if not isinstance(ref, str) or "." not in ref:
                found.append(Problem((*at, "data", "plots", i), f"data reference {ref!r} must be 'series.column'"))
            elif ref.split(".", 1)[0] not in names:
                found.append(Problem((*at, "data", "plots", i), f"data reference {ref!r} names no declared series"))
    return found


def _script(entry: dict, at: tuple, folder: Path, adapter_name: str) -> tuple[str | None, list[Problem]]:
    """The script a run of ``adapter_name`` runs (None: the entry is not for it, or has no usable script) and
    its problems (not a file of the test case). A wrong type is the schema's problem."""
    script, where = entry.get("script"), (*at, "script")
    if isinstance(script, dict):
        script, where = script.get(adapter_name), (*at, "script", adapter_name)
    elif isinstance(script, str):
        accepts = getattr(get_adapter(adapter_name), "accepts_script", None)
        if accepts is not None and not accepts(script):
            return None, []  # a plain script in another code's input language: not a run for this engine
    if not isinstance(script, str):
        return None, []
    problem = _file_in_testcase_problem(script)
    if problem:
        return script, [Problem(where, problem)]
    if not (folder / script).is_file():
        return script, [Problem(where, f"script {script!r} not found in {folder}")]
    return script, []


def _dependency_problems(items: list) -> dict[int, list[Problem]]:
    """Problems of ``depends_on`` per position in ``items`` (``_Item``): an unknown run, or a cycle (reported
    for every run on it)."""
    found: dict[int, list[Problem]] = {}
    names = [item.entry.get("name") for item in items if isinstance(item.entry, dict)]
    graph = {}
    for k, item in enumerate(items):
        if not isinstance(item.entry, dict):
            continue
        dep = item.entry.get("depends_on")
        if isinstance(item.entry.get("name"), str):  # a name of another type is the schema's problem
            graph.setdefault(item.entry["name"], dep)
        if isinstance(dep, str) and dep not in names:
            found.setdefault(k, []).append(Problem(
                ("runs", item.index, "depends_on"), f"unknown run {dep!r} (runs here: {', '.join(map(str, names))})"))
    for k, item in enumerate(items):
        if not isinstance(item.entry, dict) or not isinstance(item.entry.get("name"), str):
            continue
        start = item.entry["name"]
        seen, node = [], start
        while node in graph and isinstance(graph[node], str):
            if node in seen:
                if node == start:
                    found.setdefault(k, []).append(Problem(("runs", item.index, "depends_on"),
                                                           "dependency cycle: " + " -> ".join(map(str, seen + [node]))))
                break
            seen.append(node)
            node = graph[node]
    return found


def _duplicate_problems(items: list) -> dict[int, list[Problem]]:
    """A run name used by more than one run (after sweeps and scaling studies expanded)."""
    names = [item.entry.get("name") for item in items if isinstance(item.entry, dict)]
    found: dict[int, list[Problem]] = {}
    for k, item in enumerate(items):
        name = item.entry.get("name") if isinstance(item.entry, dict) else None
        if isinstance(name, str) and names.count(name) > 1:
            found[k] = [Problem(("runs", item.index, "name"), f"run name {name!r} is used more than once")]
    return found


def _without_broken_fields(entry: dict, problems: list[Problem], at: tuple) -> dict:
    """The entry without the fields its problems are about. A broken entry is only recorded (reason config),
    never run; what is recorded must still be plain JSON of the expected shapes (no NaN for the store,
    no list where the planner reads an object)."""
    bad = {p.path[len(at)] for p in problems if p.label is None and len(p.path) > len(at) and p.path[:len(at)] == at}
    return {key: value for key, value in entry.items() if key not in bad and not has_non_finite(value)}


def _parallelism(adapter_name: str) -> str:
    """How the adapter's code uses more cores (``EngineAdapter.parallelism``); "mpi" when it cannot be told."""
    try:
        return get_adapter(adapter_name).parallelism
    except Exception:  # noqa: BLE001 - an unknown adapter is reported where the target is read
        return "mpi"


@dataclass
class _Item:
    """One run of a run.config after sweeps and scaling studies expanded: the index of its entry in the file,
    the run's configuration, and the problems, script and typed entry of that file entry."""

    index: int
    entry: object
    problems: list[Problem]
    script: str | None = None
    typed: RunConfigEntry | None = None


def parse_run_config(data, path: Path, adapter_name: str) -> tuple[list[RunEntry], list[str]]:
    """Validate a run.config for one adapter: the run entries (with their own problems) and the problems
    of the file (file-level ones and those between entries: duplicate names, dependencies).

    A problem in one entry marks that entry invalid (it is recorded as failed, reason config); the others
    stay runnable. Problems of the file as a whole (not an object, no runs list, an entry that is no
    object, an unknown top-level field) that concern no run are carried by a pseudo run named
    ``run.config`` (``CONFIG_RUN``), so they are reported and recorded while the valid runs still run.
    JSON paths count entries as written in the file, also after a sweep expanded into several runs.
    """
    file_problems = Problems(path)
    runs = _file_level_problems(file_problems, data)
    if runs is None:
        return _with_config_run([], file_problems.found, path), file_problems.messages
    items = _items(runs, path.parent, adapter_name)
    between = _duplicate_problems(items)
    for k, problems in _dependency_problems(items).items():
        between.setdefault(k, []).extend(problems)
    entries, unattached = [], list(file_problems.found)
    for k, item in enumerate(items):
        if not isinstance(item.entry, dict):
            unattached.extend(item.problems)
            continue
        at = ("runs", item.index)
        valid_name = isinstance(item.entry.get("name"), str) \
            and not any(p.path == (*at, "name") and p.label is None for p in item.problems)
        name = item.entry["name"] if valid_name else f"runs[{item.index}]"
        problems = item.problems + between.get(k, [])
        if item.script is None and not problems and "script" in item.entry:
            continue  # this run is written for another engine
        config = _without_broken_fields(item.entry, problems, at) if problems else item.entry
        typed = None if problems else item.typed
        entries.append(RunEntry(name, config, item.script, problems, path, typed))
    reported = file_problems.found + [p for problems in between.values() for p in problems]
    reported += [p for p in unattached if p not in reported]
    return _with_config_run(entries, unattached, path), [p.line(path) for p in reported]


def _file_level_problems(problems: Problems, data) -> list | None:
    """The problems of the run.config outside its run entries (added to ``problems``) and its ``runs`` list
    (None when there is none to read)."""
    if not isinstance(data, dict):
        non_finite_problems(problems, data)
        problems.add((), "a run.config must be a JSON object with a 'runs' list")
        return None
    runs = data.get("runs")
    outside = {key: value for key, value in data.items() if key != "runs"}
    non_finite_problems(problems, outside)
    if "runs" in data and not isinstance(runs, list):
        non_finite_problems(problems, runs, "runs")
    _typed, found = check.validate(RunConfig, {**outside, **({"runs": []} if isinstance(runs, list) else
                                                              {} if runs is None else {"runs": runs})})
    problems.extend(found)
    return runs if isinstance(runs, list) else None


def _items(runs: list, folder: Path, adapter_name: str) -> list[_Item]:
    """The runs of the file's entries: a valid sweep or scaling block becomes one ordinary run per value
    (harness.config.sweep, harness.analysis.scaling); an invalid one stays to be reported as one entry."""
    parallelism = _parallelism(adapter_name)
    items = []
    for i, entry in enumerate(runs):
        found = Problems(folder)
        non_finite_problems(found, entry, "runs", i)
        if not isinstance(entry, dict):
            if not found:
                found.extend(check.validate(RunConfig, {"runs": [entry]})[1])
                found.found = [Problem(("runs", i, *p.path[2:]), p.message) for p in found.found]
            items.append(_Item(i, entry, found.found))
            continue
        problems, script, typed = _entry_problems(entry, ("runs", i), folder, adapter_name)
        problems = found.found + problems
        expandable = not found and isinstance(entry.get("name"), str) and not any(
            p.path[2:3] in (("name",), ("variables",), ("sweep",), ("scaling",)) for p in problems)
        for point in sweep.expand(entry) if expandable else [entry]:
            for scaled in scaling.expand(point, parallelism) if expandable else [point]:
                point_typed = typed if scaled is entry or problems else check.validate(RunConfigEntry, scaled)[0]
                items.append(_Item(i, scaled, problems, script, point_typed))
    return items


def _with_config_run(entries: list[RunEntry], unattached: list[Problem], path: Path) -> list[RunEntry]:
    """``entries`` and, when some problems concern no run, the pseudo run ``run.config`` carrying them."""
    if unattached:
        entries = entries + [RunEntry(CONFIG_RUN, {}, found=list(unattached), file=path)]
    return entries


def load_testcase(folder: Path, path: str, adapter) -> TestCaseSpec | None:
    """The test case in ``folder`` (identity ``path``), or None if the folder is not a test case."""
    config_file = folder / RUN_CONFIG
    generated = False
    if config_file.is_file():
        try:
            data = load_json(config_file, strict=False)
        except JsonFileError as exc:
            return TestCaseSpec(path, folder, [RunEntry(CONFIG_RUN, {}, found=[Problem((), exc.problem, "")],
                                                        file=config_file)])
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


def _testcases_repository(target: TargetDefinition):
    """The repository of the target's test cases; a missing one is a problem of the target file's field."""
    try:
        return gitrepo.open_repository(target.testcases_repository)
    except UserError as exc:
        field = "testcases_repository" if "testcases_repository" in target.raw else "repository"
        raise UserError(f"{target.path}: $.{field}: {exc} (a relative path starts at the folder that holds "
                        "the targets folder; the default is the repository holding the target file)") from None


def testcase_root(target: TargetDefinition, working_tree: bool = False) -> Path:
    """The folder the target's test case folders are relative to: the working tree or an export."""
    if working_tree or target.testcases_revision == WORKING_TREE:
        repo = _testcases_repository(target)
        if repo.bare:
            raise UserError(f"{target.path}: $.testcases_revision: {WORKING_TREE!r} needs a local checkout, "
                            f"{target.testcases_repository} is bare")
        return Path(repo.working_tree_dir)
    repo = _testcases_repository(target)
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
