"""Target definitions: ``targets/NAME.json`` after the thesis' listings 4.1 and 4.10.

A target is a named build of a DEM code at a git revision. Its fields (repository, revision, recipe and the
recipes' fields, engine, test case folders, reference, ...) are declared once, with their defaults and
meaning, in ``harness.config.target.Target`` (``harness schema target`` prints them as JSON Schema;
harness/README.md has a table). Here they are checked against that schema and what it cannot say (which
recipe requires or takes which field, folders inside the repository, patch files that exist, a reference
that is a name and not the target itself), and read into a ``TargetDefinition`` with its defaults filled in.

The target's name is its file name without ``.json``; it names folders in the workspace, so it must be a
safe single path segment (``harness.execution.workspace.segment_problem``), as must ``reference`` and every part of
a relative ``testcases`` folder. A target whose reference chain comes back to itself, or leads into such a
cycle or to a broken or unknown target, is reported (``$.reference``) and left out.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath

from harness.adapters.base import UserError
from harness.config import check
from harness.config.jsonfile import Problem, Problems, load_json, non_finite_problems
from harness.config.target import WORKING_TREE, Target
from harness.execution.workspace import PROJECT_ROOT, segment_problem

#: fields that change the binary; the build cache is keyed by their hash and the commit
BUILD_KEYS = ("repository", "recipe", "source_folder", "make_target", "make_variables", "generated_executable",
              "executable")
#: build fields added later: hashed only when a definition sets them, so older targets keep their builds
OPTIONAL_BUILD_KEYS = ("configure", "cmake_options", "build_type", "build_targets", "prebuild", "postbuild",
                       "env", "export", "patches")
#: fields of the make and cmake recipes only
BUILD_RECIPE_KEYS = ("configure", "cmake_options", "build_type", "build_targets", "prebuild", "postbuild", "env",
                     "jobs", "ccache", "export", "requires", "patches")


def targets_dir() -> Path:
    return Path(os.environ.get("HARNESS_TARGETS", PROJECT_ROOT / "targets")).expanduser().resolve()


@dataclass
class TargetDefinition:
    name: str
    path: Path
    raw: dict
    repository: str
    revision: str
    recipe: str
    source_folder: str
    engine: str
    testcases: list[str]
    testcases_repository: str
    testcases_revision: str
    reference: str | None = None
    make_target: str | None = None
    make_variables: dict = field(default_factory=dict)
    make_jobs: int = 1
    generated_executable: str | None = None
    executable: str | None = None
    thermo_columns: dict = field(default_factory=dict)
    mpi_launcher: list[str] = field(default_factory=lambda: ["mpirun"])
    configure: list[str] = field(default_factory=list)
    cmake_options: dict = field(default_factory=dict)
    build_type: str = "Release"
    build_targets: list[str] = field(default_factory=list)
    prebuild: list[str] = field(default_factory=list)
    postbuild: list[str] = field(default_factory=list)
    env: dict = field(default_factory=dict)
    jobs: int | None = None
    ccache: bool | None = None
    export: list[str] = field(default_factory=list)
    requires: list[dict] = field(default_factory=list)
    #: [{"from", "before", "files": [Path], "env", "cmake_options"}]
    patches: list[dict] = field(default_factory=list)
    on_demand: bool = False
    #: the revision was given on the command line (``TARGET@REV``): its build does not become the current one
    explicit_revision: bool = False

    @property
    def definition_hash(self) -> str:
        """sha256 of the build-relevant fields (the build cache key together with the commit); the patch
        files count by their content."""
        relevant = {key: getattr(self, key) for key in BUILD_KEYS}
        for key in OPTIONAL_BUILD_KEYS:
            if key in self.raw:
                relevant[key] = self.raw[key]
        if self.patches:
            relevant["patch_content"] = [[_file_digest(f) for f in entry["files"]] for entry in self.patches]
        return hashlib.sha256(json.dumps(relevant, sort_keys=True).encode()).hexdigest()

    def as_dict(self) -> dict:
        return dict(self.raw)


def _file_digest(path: Path) -> str:
    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError as exc:
        raise UserError(f"{path}: {exc.strerror or exc}") from None


def _enclosing_repository(path: Path) -> Path:
    """The git checkout holding ``path`` (the project's own repository for ``targets/*.json``)."""
    for folder in [path.resolve().parent, *path.resolve().parents]:
        if (folder / ".git").exists():
            return folder
    return PROJECT_ROOT


def _resolve_repository(value: str | None, base: Path) -> str:
    if not value:
        return str(_enclosing_repository(base / "targets"))
    if "://" in value or value.startswith("git@"):
        return value
    path = Path(value).expanduser()
    return str(path if path.is_absolute() else (base / path).resolve())


def parse_target(name: str, data, path: Path) -> TargetDefinition:
    """Validate a target definition against the schema (``harness.config.target``) and what it cannot say;
    every problem names the file and the JSON path (a UserError listing them)."""
    problems = Problems(path)
    problem = segment_problem(name)
    if problem:
        # the name becomes a folder of the workspace (builds/<name>/, runs/<machine>/<name>/)
        problems.add("file name", f"target name {problem}")
    non_finite_problems(problems, data)
    if not isinstance(data, dict):
        problems.add((), "a target definition must be a JSON object")
        problems.raise_if_any()
    problems.extend(check.validate(Target, data)[1])
    recipe = data.get("recipe") or ("make" if "make_target" in data else "system" if "executable" in data
                                    else "dem")
    problems.extend(_recipe_problems(data, recipe) + _folder_problems(data, path) + _reference_problems(data, name))
    problems.raise_if_any()
    return _definition(name, data, path, recipe)


def _definition(name: str, data: dict, path: Path, recipe: str) -> TargetDefinition:
    """The definition of a valid target file ``data``: defaults filled in, paths resolved."""
    base = path.resolve().parent.parent
    patches = [{"from": entry.get("from"), "before": entry.get("before"),
                "files": [(path.resolve().parent / f).resolve() for f in entry.get("files", [])],
                "env": {k: str(v) for k, v in entry.get("env", {}).items()},
                "cmake_options": {k: str(v) for k, v in entry.get("cmake_options", {}).items()}}
               for entry in data.get("patches", [])]
    requires = [{"executable": item, "package": item} if isinstance(item, str) else dict(item)
                for item in data.get("requires", [])]
    source_folder = data.get("source_folder", "engine" if recipe == "dem" else ".")
    revision = data.get("revision", "HEAD")
    repository = _resolve_repository(data.get("repository"), base)
    testcases_revision = data.get("testcases_revision") or (WORKING_TREE if revision == "HEAD" else revision)
    return TargetDefinition(
        name=name, path=path, raw=data, repository=repository, revision=revision, recipe=recipe,
        source_folder=source_folder,
        engine=data.get("engine", "dem"), testcases=list(data.get("testcases", ["testcases"])),
        testcases_repository=_resolve_repository(data.get("testcases_repository"), base)
        if data.get("testcases_repository") else repository,
        testcases_revision=testcases_revision, reference=data.get("reference"),
        make_target=data.get("make_target"), make_variables={k: str(v) for k, v in
                                                              data.get("make_variables", {}).items()},
        make_jobs=data.get("make_jobs", 1), generated_executable=data.get("generated_executable"),
        executable=data.get("executable"), thermo_columns=dict(data.get("thermo_columns", {})),
        mpi_launcher=list(data.get("mpi_launcher", ["mpirun"])),
        configure=list(data.get("configure", [])),
        cmake_options={k: str(v) for k, v in data.get("cmake_options", {}).items()},
        build_type=data.get("build_type", "Release"), build_targets=list(data.get("build_targets", [])),
        prebuild=list(data.get("prebuild", [])), postbuild=list(data.get("postbuild", [])),
        env={k: str(v) for k, v in data.get("env", {}).items()},
        jobs=data.get("jobs", data.get("make_jobs")), ccache=data.get("ccache"),
        export=list(data.get("export", [source_folder])), requires=requires, patches=patches,
        on_demand=bool(data.get("on_demand", False)),
    )


def _recipe_problems(data: dict, recipe: str) -> list[Problem]:
    """Fields a recipe requires, and fields only other recipes take."""
    found = []
    if recipe == "make":
        found += [Problem((key,), "required for the make recipe") for key in ("make_target", "generated_executable")
                  if key not in data]
    if recipe == "cmake" and "generated_executable" not in data:
        found.append(Problem(("generated_executable",), "required for the cmake recipe (the program's path in "
                                                        "the build folder)"))
    if recipe == "system" and "executable" not in data:
        found.append(Problem(("executable",), "required for the system recipe"))
    if recipe not in ("make", "cmake"):
        found += [Problem((key,), f"only for the make and cmake recipes (this target's is {recipe!r})")
                  for key in BUILD_RECIPE_KEYS if key in data]
    else:
        for key in ("configure", "cmake_options", "build_type", "build_targets"):
            only = "make" if key == "configure" else "cmake"
            if key in data and recipe != only:
                found.append(Problem((key,), f"only for the {only} recipe"))
    return found


def _folder_problems(data: dict, path: Path) -> list[Problem]:
    """Folders and files the definition names: test case folders and exports that stay inside the
    repository, patch files that exist, requirements that name something."""
    found = []
    testcases = data.get("testcases")
    for i, item in enumerate(testcases if isinstance(testcases, list) else []):
        problem = _testcases_folder_problem(item) if isinstance(item, str) else None
        if problem:
            found.append(Problem(("testcases", i), problem))
    export = data.get("export")
    for item in export if isinstance(export, list) else []:
        if isinstance(item, str) and (item.startswith("/") or ".." in PurePosixPath(item).parts):
            found.append(Problem(("export",), f"folder {item!r} must be relative to the repository root, "
                                              "without '..'"))
    requires = data.get("requires")
    for i, item in enumerate(requires if isinstance(requires, list) else []):
        if item == {}:
            found.append(Problem(("requires", i), 'an object has "executable" and/or "package" (strings)'))
    patches = data.get("patches")
    for i, entry in enumerate(patches if isinstance(patches, list) else []):
        files = entry.get("files") if isinstance(entry, dict) else None
        for j, name in enumerate(files if isinstance(files, list) else []):
            if isinstance(name, str) and not (path.resolve().parent / name).is_file():
                found.append(Problem(("patches", i, "files", j), f"patch file {name!r} not found (relative to "
                                                                  f"{path.resolve().parent})"))
    return found


def _reference_problems(data: dict, name: str) -> list[Problem]:
    """A reference is read from ``<reference>.json`` next to this file: a name, never a path, not itself."""
    reference = data.get("reference")
    if not isinstance(reference, str):
        return []
    problem = segment_problem(reference)
    if problem:
        return [Problem(("reference",), f"target {problem}")]
    if reference == name:
        return [Problem(("reference",), "a target cannot be its own reference")]
    return []


def _testcases_folder_problem(folder: str) -> str | None:
    """Why a ``testcases`` entry cannot name test case folders (None: it can).

    A relative folder's parts become the test case paths, and those name folders in the workspace: each
    must be a safe name (no ``..``, which would leave the repository). An absolute folder is read as it
    is; only its last part becomes a name.
    """
    if not folder.strip():
        return "must name a folder"
    path = PurePosixPath(folder)
    parts = (path.name,) if path.is_absolute() else path.parts
    for part in parts:
        problem = segment_problem(part)
        if problem:
            return f"folder {folder!r}: {problem}"
    return None


def load_target_file(path: Path) -> TargetDefinition:
    path = Path(path)
    return parse_target(path.stem, load_json(path, strict=False), path)


def load_targets(folder: Path | None = None) -> tuple[dict[str, TargetDefinition], list[str]]:
    """All targets in ``folder`` (default ``targets_dir()``) and the problems of the ones that failed.

    A target whose reference is unknown is reported and left out; the others are kept.
    """
    targets, problems, _left_out = _load_targets(folder)
    return targets, problems


def _load_targets(folder: Path | None) -> tuple[dict[str, TargetDefinition], list[str], dict[str, str]]:
    """``load_targets`` and, by target name, the problem that left each broken target out."""
    folder = Path(folder) if folder else targets_dir()
    targets: dict[str, TargetDefinition] = {}
    problems: list[str] = []
    left_out: dict[str, str] = {}

    def leave_out(name: str, problem: str) -> None:
        problems.append(problem)
        left_out.setdefault(name, problem)

    for path in sorted(folder.glob("*.json")) if folder.is_dir() else []:
        try:
            targets[path.stem] = load_target_file(path)
        except UserError as exc:
            leave_out(path.stem, str(exc))
    broken = set(left_out)
    references = {name: target.reference for name, target in targets.items()}
    for name in sorted(targets):
        cycle = _reference_cycle(name, references)
        if cycle and cycle[0] == name:  # on the cycle; a target leading into one is handled below
            leave_out(name, f"{targets[name].path}: $.reference: reference cycle {' -> '.join(cycle)} "
                      "(a target cannot be compared with itself, also not through others)")
            broken.add(name)
    for name in broken & set(targets):
        del targets[name]
    # what leads to a left-out target is left out too, until nothing changes (a chain a -> b -> c)
    changed = True
    while changed:
        changed = False
        for name, target in list(targets.items()):
            if target.reference and target.reference not in targets:
                what = (f"target {target.reference!r} is not usable (see the problem of "
                        f"{target.reference}.json)" if target.reference in broken
                        else f"unknown target {target.reference!r}")
                leave_out(name, f"{target.path}: $.reference: {what}")
                del targets[name]
                broken.add(name)
                changed = True
    return targets, problems, left_out


def _reference_cycle(start: str, references: dict[str, str | None]) -> list[str] | None:
    """The cycle ``start`` lies on (``[start, ..., start]``), the cycle its chain runs into (not starting
    with ``start``), or None when the chain ends."""
    chain, node = [start], references.get(start)
    while node is not None and node in references:
        if node in chain:
            return chain[chain.index(node):] + [node]
        chain.append(node)
        node = references.get(node)
    return None


def select_targets(names: list[str], folder: Path | None = None) -> tuple[list[TargetDefinition], list[str]]:
    """Targets by name (or path to a ``.json`` file); all targets when ``names`` is empty.

    A named target that does not exist is a UserError; broken target files are returned as problems.
    """
    all_targets, problems, left_out = _load_targets(folder)
    if not names:  # on-demand targets (a cold build costs minutes) only when named
        return [t for t in all_targets.values() if not t.on_demand], problems
    chosen = []
    for name in names:
        if name.endswith(".json") and Path(name).is_file():
            chosen.append(load_target_file(Path(name)))
        elif name in all_targets:
            chosen.append(all_targets[name])
        else:
            if name in left_out:
                raise UserError(left_out[name])
            known = ", ".join(sorted(all_targets)) or "none"
            raise UserError(f"unknown target {name!r} (known in {folder or targets_dir()}: {known})")
    return chosen, problems


def with_testcases(target: TargetDefinition, folder: str | Path | None) -> TargetDefinition:
    """``target`` with its test case folders replaced by ``folder`` (made absolute: read as it is on disk, no
    git), for ``harness run --testcases`` and ``harness validate --testcases``; unchanged without one."""

    if not folder:
        return target
    return dataclasses.replace(target, testcases=[str(Path(folder).expanduser().resolve())])


def reference_of(target: TargetDefinition, folder: Path | None = None) -> TargetDefinition | None:
    """The reference target's definition (from the same folder as ``target``), or None."""
    if not target.reference:
        return None
    path = target.path.parent / f"{target.reference}.json"
    if not path.is_file():
        raise UserError(f"{target.path}: $.reference: unknown target {target.reference!r}")
    reference = load_target_file(path)
    # a target loaded from its file (not through load_targets) may still sit on a reference cycle: follow
    # the chain through the files; a broken file further down is the problem of whoever needs it
    chain, current = [target.name, reference.name], reference
    while current.reference:
        if current.reference in chain:
            cycle = chain[chain.index(current.reference):] + [current.reference]
            raise UserError(f"{target.path}: $.reference: reference cycle {' -> '.join(cycle)} "
                            "(a target cannot be compared with itself, also not through others)")
        following = current.path.parent / f"{current.reference}.json"
        try:
            current = load_target_file(following)
        except UserError:
            break
        chain.append(current.name)
    return reference
