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
of dumps), and the acceptance keys ``expectations`` / ``stability`` (checked by ``harness.acceptance``).

A folder without run.config may still be a test case if the adapter supplies a default configuration
(``EngineAdapter.default_run_config``, e.g. one serial run per LIGGGHTS ``in.*`` script).
"""
from __future__ import annotations

import fnmatch
import hashlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path

from harness import gitrepo
from harness.adapters.base import UserError
from harness.jsonfile import Problems, expect_type, json_path, load_json
from harness.targets import WORKING_TREE, TargetDefinition
from harness.workspace import RESERVED_NAMES, workspace

RUN_CONFIG = "run.config"
RUN_TYPES = ("serial", "mpi", "mpi/custom")
DEFAULT_TIMEOUT = 600.0
#: folders of a test case that never hold a nested test case (thesis 4.3.1)
NOT_TESTCASES = RESERVED_NAMES
#: never part of a test case's content: its output folder (but post/restart/), records, version control
_NOT_CONTENT = {"post", "run.json", ".git", "__pycache__"}
RUN_KEYS = {"name", "type", "nprocs", "mpi_options", "script", "variables", "depends_on", "post_scripts", "data",
            "timeout", "thermo_columns", "consistency", "vtk", "expectations", "stability", "description",
            "sweep", "sweep_point"}
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
        ``post/`` it receives). A change to any of them makes it another run (harness.runner)."""
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


def _validate_entry(problems: Problems, entry: dict, i: int, folder: Path, adapter_name: str) -> str | None:
    """Validate one run configuration; returns the script for ``adapter_name`` (None: not for it)."""
    at = ["runs", i]
    for key in sorted(set(entry) - RUN_KEYS):
        problems.add(json_path(*at, key), f"unknown field (known: {', '.join(sorted(RUN_KEYS))})")
    if "name" not in entry:
        problems.add(json_path(*at, "name"), "required")
    else:
        expect_type(problems, json_path(*at, "name"), entry["name"], str, "a string")
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
        elif not isinstance(options, (str, list)):
            problems.add(json_path(*at, "mpi_options"), "must be a string or a list of strings")
    for key in ("variables", "thermo_columns", "consistency", "vtk"):
        if key in entry:
            expect_type(problems, json_path(*at, key), entry[key], dict, "an object")
    for name, value in (entry.get("variables") or {}).items() if isinstance(entry.get("variables"), dict) else ():
        expect_type(problems, json_path(*at, "variables", name), value, (str, int, float), "a string or number")
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
            if expect_type(problems, json_path(*at, "post_scripts", j), script, str, "a file name") \
                    and not (folder / script).is_file():
                problems.add(json_path(*at, "post_scripts", j), f"post script {script!r} not found in {folder}")
    if "data" in entry:
        _validate_data(problems, entry["data"], [*at, "data"])
    try:
        from harness import acceptance
    except ImportError:
        acceptance = None
    if acceptance is not None and ("expectations" in entry or "stability" in entry):
        for message in acceptance.validate(entry):
            problems.add(json_path(*at), message)
    from harness import sweep

    for message in sweep.validate(entry):
        problems.add(json_path(*at), message)

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
    if isinstance(script, str) and not (folder / script).is_file():
        problems.add(where, f"script {script!r} not found in {folder}")
    return script


def _dependency_problems(problems: Problems, runs: list[dict]) -> None:
    names = [r.get("name") for r in runs if isinstance(r, dict)]
    for i, entry in enumerate(runs):
        if not isinstance(entry, dict):
            continue
        dep = entry.get("depends_on")
        if isinstance(dep, str) and dep not in names:
            problems.add(json_path("runs", i, "depends_on"), f"unknown run {dep!r} (runs here: {', '.join(map(str, names))})")
    graph = {r.get("name"): r.get("depends_on") for r in runs if isinstance(r, dict)}
    for start in graph:
        seen, node = [], start
        while node in graph and graph[node] is not None:
            if node in seen:
                cycle = seen[seen.index(node):] + [node]
                if start == node:
                    problems.add(json_path("runs"), "dependency cycle: " + " -> ".join(map(str, cycle)))
                break
            seen.append(node)
            node = graph[node]


def parse_run_config(data, path: Path, adapter_name: str) -> tuple[list[RunEntry], list[str]]:
    """Validate a run.config for one adapter: the run entries (with their own problems) and file problems.

    A problem in one entry marks that entry invalid; the others stay runnable. A file-level problem (not
    an object, no runs list, duplicate names, dependency cycle) is returned separately.
    """
    folder = path.parent
    file_problems = Problems(path)
    if not isinstance(data, dict):
        file_problems.add("$", "a run.config must be a JSON object with a 'runs' list")
        return [], file_problems.messages
    runs = data.get("runs")
    if runs is None:
        file_problems.add(json_path("runs"), "required")
        return [], file_problems.messages
    if not expect_type(file_problems, json_path("runs"), runs, list, "a list of run configurations"):
        return [], file_problems.messages
    # a valid sweep block becomes one ordinary run per value (harness.sweep); an invalid one stays to be reported
    from harness import sweep

    runs = [point for entry in runs
            for point in (sweep.expand(entry) if isinstance(entry, dict) and not sweep.validate(entry)
                          and isinstance(entry.get("name"), str) else [entry])]
    for key in sorted(set(data) - {"runs", "description"}):
        file_problems.add(json_path(key), "unknown field (known: runs, description)")
    names = [r.get("name") for r in runs if isinstance(r, dict)]
    for name in sorted({n for n in names if isinstance(n, str) and names.count(n) > 1}):
        file_problems.add(json_path("runs"), f"run name {name!r} is used more than once")
    _dependency_problems(file_problems, runs)
    entries = []
    for i, entry in enumerate(runs):
        problems = Problems(path)
        if not expect_type(problems, json_path("runs", i), entry, dict, "a run configuration object"):
            file_problems.messages.extend(problems.messages)
            continue
        script = _validate_entry(problems, entry, i, folder, adapter_name)
        name = entry.get("name") if isinstance(entry.get("name"), str) else f"runs[{i}]"
        if script is None and not problems and "script" in entry:
            continue  # this run is written for another engine
        entries.append(RunEntry(name=name, config=entry, script=script, problems=problems.messages))
    # a dependency problem concerns the runs in it: attach file-level problems to every entry
    if file_problems:
        for entry in entries:
            entry.problems = file_problems.messages + entry.problems
    return entries, file_problems.messages


def load_testcase(folder: Path, path: str, adapter) -> TestCaseSpec | None:
    """The test case in ``folder`` (identity ``path``), or None if the folder is not a test case."""
    config_file = folder / RUN_CONFIG
    generated = False
    if config_file.is_file():
        try:
            data = load_json(config_file)
        except UserError as exc:
            return TestCaseSpec(path, folder, [RunEntry(CONFIG_RUN, {}, problems=[str(exc)])])
    else:
        data = adapter.default_run_config(folder)
        if data is None:
            return None
        generated = True
    entries, file_problems = parse_run_config(data, config_file, adapter.name)
    if file_problems and not entries:
        entries = [RunEntry(CONFIG_RUN, {}, problems=file_problems)]
    return TestCaseSpec(path, folder, entries, generated)


def _walk(root: Path, base: Path, prefix: str, adapter) -> list[TestCaseSpec]:
    found = []
    if not root.is_dir():
        return found
    for current, dirs, _files in os.walk(root):
        current = Path(current)
        dirs[:] = sorted(d for d in dirs if d not in NOT_TESTCASES and not d.startswith("."))
        rel = current.relative_to(base).as_posix()
        spec = load_testcase(current, f"{prefix}{rel}" if prefix else rel, adapter)
        if spec is not None:
            found.append(spec)
    return found


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
    """The test cases of a target and problems (missing test case folders)."""
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
        for spec in _walk(path, base, prefix, adapter):
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
