"""Building targets (thesis 4.2): resolve the revision, export the source, run the recipe, cache the result.

Builds are cached in ``<workspace>/builds/<target>/<commit>-<definition hash>/`` and count only once the
recipe finished and the ``done`` marker is written (a crash mid-build leaves no half build that looks
usable). The build log is kept as ``build.log`` and in the store. The current build of a target is the one
of the commit its revision resolves to now (``record_current_build`` records it,
``current_build`` reads it); the results of its other builds are
outdated (thesis 4.3.4) but kept, with their run folders.
"""
from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
from datetime import datetime, timezone
from pathlib import Path

import git
from filelock import Timeout

from harness.adapters.base import UserError
from harness.config import gitrepo
from harness.config.targets import TargetDefinition
from harness.execution.workspace import workspace
from harness.store.rules import restored_state

DONE_MARKER = "done"
#: failure reason of the runs of a target whose build failed (they are not executed)
BUILD_FAILED = "build_failed"


class BuildError(UserError):
    """A recipe failed; the message names the target and points at the kept log."""


def _now():
    return datetime.now(timezone.utc)


def ensure_machine(name: str):
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Machine

    return Machine.objects.get_or_create(name=name)[0]


def ensure_target(target: TargetDefinition):
    """The store's row for a target definition (created or updated), linked to its reference's row."""
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Target

    row, _ = Target.objects.get_or_create(name=target.name)
    row.definition = target.as_dict()
    # a definition that dropped its reference drops it in the store too
    row.reference = Target.objects.get_or_create(name=target.reference)[0] if target.reference else None
    row.save()
    return row


def sha256_file(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _system_executable(target: TargetDefinition) -> Path:
    found = shutil.which(target.executable)
    if not found:
        raise UserError(f"{target.path}: $.executable: {target.executable!r} not found or not executable")
    return Path(found).resolve()


def resolve_commit(target: TargetDefinition) -> dict:
    """What the target's revision is now: ``commit`` plus date and message where git knows them."""
    if target.recipe == "system":
        binary = _system_executable(target)
        return {"commit": sha256_file(binary), "committed_at": None,
                "commit_message": f"system executable {binary}"}
    repo = gitrepo.open_repository(target.repository)
    return gitrepo.commit_info(gitrepo.resolve(repo, target.revision))


def make_current(build) -> None:
    """Record ``build`` as the current build of its target on its machine (thesis 4.3.4).

    The runs of every other build of that target and machine become outdated; runs of this build that an
    earlier switch made outdated come back (a revision built again is current again, its results valid),
    except those a newer run of the same test case content replaced (``harness.store.records.store_record``).
    """
    # the store's models (Django) load once Django is set up (harness.store)
    from django.db import transaction

    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Build, Run

    with transaction.atomic():
        siblings = Build.objects.filter(target_id=build.target_id, machine_id=build.machine_id)
        siblings.exclude(pk=build.pk).filter(current=True).update(current=False)
        if not build.current:
            Build.objects.filter(pk=build.pk).update(current=True)
            build.current = True
        (Run.objects.filter(target_id=build.target_id, machine_id=build.machine_id)
         .exclude(build=build).exclude(state=Run.State.OUTDATED).update(state=Run.State.OUTDATED))
        for run in Run.objects.filter(build=build, state=Run.State.OUTDATED, replaced=False):
            run.state = restored_state(run)
            run.save(update_fields=["state", "updated"])


def find_build(target: TargetDefinition, machine_name: str, info: dict | None = None):
    """The complete build of the commit ``target``'s revision resolves to now, or None."""
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Build

    info = info or resolve_commit(target)
    return Build.objects.filter(target__name=target.name, machine__name=machine_name, commit=info["commit"],
                                definition_hash=target.definition_hash, status=Build.Status.COMPLETE).first()


def failed_build(target: TargetDefinition, machine_name: str):
    """The stored failed build (not an interrupted one) of the commit ``target``'s revision resolves to now,
    or None; it becomes current unless the revision was given on the command line (``TARGET@REV``). Its runs
    are recorded failed with reason ``BUILD_FAILED`` (``harness.analysis.coverage.record_build_failure``) and JUnit shows it as the
    failing test case ``build`` (``harness.report.junit.build_failure_suite``)."""
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Build

    info = resolve_commit(target)
    build = Build.objects.filter(target__name=target.name, machine__name=machine_name, commit=info["commit"],
                                 definition_hash=target.definition_hash, status=Build.Status.FAILED).first()
    if build is None or (build.details or {}).get("interrupted") or build.finished is None:
        return None
    if not target.explicit_revision:
        make_current(build)
    return build


def current_build(target_name: str, machine_name: str):
    """The recorded current build of a target on a machine (complete), or None. Reads the store only: no
    git command, nothing written - the dashboard and every reader of the store ask this."""
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Build

    return Build.objects.filter(target__name=target_name, machine__name=machine_name, current=True,
                                status=Build.Status.COMPLETE).first()


def record_current_build(target: TargetDefinition, machine_name: str):
    """Resolve ``target``'s revision now and record the complete build of that commit as its current build
    (``make_current``); returns it, or None when that commit is not built here (nothing recorded then).

    ``build``, ``run``, ``check``, ``status``, ``sweep``, ``list`` and ``matrix`` call it before they read
    the current build. A revision given on the command line (``TARGET@REV``) names its build without making
    it current.
    """
    build = find_build(target, machine_name)
    if build is not None and not target.explicit_revision:
        make_current(build)
    return build


def build_target(target: TargetDefinition, machine_name: str, force: bool = False, log=None,
                 jobs: int | None = None):
    """Build ``target`` at its revision on this machine, or return the cached build; it becomes current
    unless the revision was given on the command line (``TARGET@REV``).

    ``log`` is a callable taking a line of progress text (default: nothing); ``jobs`` overrides the
    target's parallel compile jobs. The requirements are checked first (``check_requirements``). Two
    processes building the same target and commit wait for each other (a lock per build folder) and build
    it once. A failed build is stored (status failed, log, duration, first error line) and raises
    BuildError; asking again gives the stored failure without building, unless ``force`` (or the failed
    attempt was interrupted). A failed build of the revision becomes current as a complete one does.
    """
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Build, Run

    say = log or (lambda text: None)
    check_requirements(target)
    machine = ensure_machine(machine_name)
    target_row = ensure_target(target)
    info = resolve_commit(target)
    ws = workspace()
    key = f"{info['commit'][:12]}-{target.definition_hash[:8]}"
    folder = ws.builds / target.name / key
    lock = ws.lock(f"build-{target.name}-{key}")
    try:
        lock.acquire(timeout=1)
    except Timeout:
        say(f"waiting for another harness process building {target.name} at {info['commit'][:12]} ...")
        lock.acquire()
    try:
        build, _ = Build.objects.get_or_create(
            target=target_row, machine=machine, commit=info["commit"], definition_hash=target.definition_hash,
            defaults={"revision": target.revision})
        if (build.status == Build.Status.FAILED and not force and not (build.details or {}).get("interrupted")
                and build.finished is not None):
            if not target.explicit_revision:
                make_current(build)
            raise BuildError(failure_message(target.name, build) + " - a stored result; --force builds it again")
        if not (build.status == Build.Status.COMPLETE and not force and (folder / DONE_MARKER).is_file()):
            try:
                _run_recipe(target, build, info, folder, say, jobs)
            except BuildError:
                # the revision resolves to a commit that does not build: that failed build is its current
                # build (its runs are failed build_failed; the runs of the build before are outdated)
                if not target.explicit_revision:
                    make_current(build)
                raise
            if force:
                # a forced rebuild replaces the binary of this commit too: its results are outdated
                build.runs.exclude(state=Run.State.OUTDATED).update(state=Run.State.OUTDATED, replaced=True)
        if not target.explicit_revision:
            make_current(build)
        return build
    finally:
        lock.release()


def failure_message(name: str, build) -> str:
    """One line for a failed build: target, commit, first error line, log file."""
    details = build.details or {}
    return (f"build of target {name!r} at {build.commit[:12]} failed: {details.get('error') or 'see the log'} "
            f"(log: {Path(build.folder) / 'build.log'})")


def check_requirements(target: TargetDefinition) -> None:
    """Raise a one-line UserError for the first requirement of ``target`` that this machine lacks.

    An executable is looked up on PATH; a Debian package (when only a package is named, or the executable is
    missing) is asked of ``dpkg-query`` where it exists. The message names the package and its install
    command.
    """
    for item in target.requires:
        executable, package = item.get("executable"), item.get("package")
        if executable and shutil.which(executable):
            continue
        if not executable and package and _package_installed(package) is not False:
            continue
        what = f"executable {executable!r}" if executable else f"Debian package {package}"
        install = f": install it with 'sudo apt-get install {package}'" if package else ""
        raise UserError(f"{target.path}: $.requires: target {target.name!r} needs {what}, which is not "
                        f"installed{install}")


def _package_installed(package: str) -> bool | None:
    """Whether a Debian package is installed (None: no dpkg-query here, nothing to ask)."""
    if not shutil.which("dpkg-query"):
        return None
    result = subprocess.run(["dpkg-query", "-W", "-f=${Status}", package], capture_output=True, text=True)
    return result.returncode == 0 and result.stdout.strip().endswith(" installed")


#: lines that start a compiler's, linker's or build system's error message, most specific first
_ERROR_PATTERNS = (
    re.compile(r"^\S.*?:\d+(:\d+)?: (fatal )?error: .*"),    # gcc/clang: file:line:col: error: ...
    re.compile(r"^CMake Error.*"),
    re.compile(r"^error: patch failed: .*"),                  # git apply: the file and line that did not match
    re.compile(r".*undefined reference to .*"),
    re.compile(r".*\berror\b.*", re.IGNORECASE),
)


def first_error_line(log: str) -> str | None:
    """The first error line of a build log (the compiler's ``file:line: error:``, else CMake's, a patch's,
    the linker's, else any line saying error), stripped; None when there is none."""
    lines = log.splitlines()
    for pattern in _ERROR_PATTERNS:
        for index, line in enumerate(lines):
            if pattern.match(line.strip()):
                text = line.strip()
                if text.startswith("CMake Error") and index + 1 < len(lines) and lines[index + 1].strip():
                    text += " " + lines[index + 1].strip()
                return text[:500]
    return None


def _run_recipe(target: TargetDefinition, build, info: dict, folder: Path, say, jobs: int | None) -> None:
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Build

    say(f"building {target.name} at {info['commit'][:12]} ({target.recipe})")
    workspace().fresh_folder(folder)
    build.revision = target.revision
    build.committed_at = datetime.fromisoformat(info["committed_at"]) if info["committed_at"] else None
    build.commit_message = info["commit_message"]
    build.status = Build.Status.BUILDING
    build.folder = str(folder)
    build.started, build.finished, build.log = _now(), None, ""
    build.details = {"recipe": target.recipe}
    build.save()
    log_path = folder / "build.log"
    context = BuildContext(target, info["commit"], folder, jobs or target.jobs or os.cpu_count() or 1,
                           build.details)
    try:
        with open(log_path, "w", encoding="utf-8") as log_file:
            context.log_file = log_file
            executable, environment = RECIPES[target.recipe](target, info["commit"], folder, context)
    except (UserError, KeyboardInterrupt) as exc:
        interrupted = isinstance(exc, KeyboardInterrupt)
        build.status = Build.Status.FAILED
        build.log = _read_text(log_path) + (f"\n{exc}\n" if not interrupted else "\ninterrupted\n")
        build.finished = _now()
        build.details["duration_s"] = (build.finished - build.started).total_seconds()
        build.details["error"] = "interrupted" if interrupted else (first_error_line(build.log) or str(exc))
        build.details["interrupted"] = interrupted
        build.save()
        if interrupted:
            raise
        tail = "\n".join(build.log.strip().splitlines()[-15:])
        raise BuildError(f"{failure_message(target.name, build)}\n{tail}") from None
    (folder / DONE_MARKER).write_text(json.dumps({"commit": info["commit"], "executable": executable}))
    build.status = Build.Status.COMPLETE
    build.executable = json.dumps(executable)
    build.environment = environment
    build.log = _read_text(log_path)
    build.finished = _now()
    build.details["duration_s"] = (build.finished - build.started).total_seconds()
    build.save()


def _read_text(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return ""


class BuildContext:
    """What a recipe needs besides the definition: the log, the job count, the environment of its commands
    (``env`` of the target and of its matching ``patches`` entries, ccache) and the details it records."""

    def __init__(self, target: TargetDefinition, commit: str, folder: Path, jobs: int, details: dict):
        self.target, self.commit, self.folder, self.jobs, self.details = target, commit, folder, jobs, details
        self.log_file = None
        self.ccache_before: dict = {}
        self.env = dict(target.env)
        self.cmake_options = dict(target.cmake_options)
        self.details["jobs"] = jobs

    def say(self, text: str) -> None:
        self.log_file.write(text.rstrip("\n") + "\n")
        self.log_file.flush()

    def environment(self) -> dict:
        env = dict(os.environ)
        env.update(self.env)
        return env

    def run(self, command, cwd: Path, shell: bool = False, what: str | None = None) -> None:
        """Run one build command with its output in the log; UserError when it fails.

        The command runs in its own process group, which is stopped when the harness is interrupted
        (Ctrl-C, SIGTERM), so no compiler goes on writing into a build folder that no longer counts.
        """
        shown = command if shell else " ".join(command)
        self.say(f"$ cd {cwd} && {shown}")
        self.details.setdefault("commands", []).append(shown)
        process = subprocess.Popen(["sh", "-c", command] if shell else command, cwd=cwd, stdout=self.log_file,
                                   stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, env=self.environment(),
                                   start_new_session=True)
        try:
            code = process.wait()
        except BaseException:
            _stop_group(process)
            raise
        if code != 0:
            raise UserError(f"{what or shown.split()[0]} exited with code {code}")


def _stop_group(process: subprocess.Popen) -> None:
    try:
        os.killpg(process.pid, signal.SIGTERM)
        process.wait(timeout=10)
    except (ProcessLookupError, subprocess.TimeoutExpired):
        try:
            os.killpg(process.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        process.wait()


def _build_dem(target: TargetDefinition, commit: str, folder: Path, context: BuildContext):
    """The bundled engine: ``engine/`` exported at the commit, run as ``python -m engine``."""
    log_file = context.log_file
    repo = gitrepo.open_repository(target.repository)
    source = gitrepo.export(repo, commit, target.source_folder, folder / "src")
    log_file.write(f"exported {target.source_folder} at {commit} from {target.repository} to {source}\n")
    package = source.name
    if not (source / "__main__.py").is_file():
        raise UserError(f"{target.source_folder}/__main__.py does not exist at {commit[:12]}: not a runnable engine")
    return [sys.executable, "-m", package], {"PYTHONPATH": str(folder / "src")}


def _prepare_source(target: TargetDefinition, commit: str, context: BuildContext) -> Path:
    """Export the target's folders at ``commit`` into ``<build>/src``, apply the patches of the ranges the
    commit lies in (adding their env and CMake options), set up ccache and run ``prebuild``.

    Returns the export root.
    """
    root = context.folder / "src"
    repo = gitrepo.open_repository(target.repository)
    gitrepo.export(repo, commit, target.export, root)
    context.say(f"exported {', '.join(target.export)} at {commit} from {target.repository}")
    # git apply outside a repository: never look for the workspace's enclosing checkout
    context.env.setdefault("GIT_CEILING_DIRECTORIES", str(context.folder))
    applied = []
    for entry in target.patches:
        if not _in_range(repo, commit, entry):
            continue
        for patch in entry["files"]:
            context.run(["git", "apply", "-p1", "--verbose", "--whitespace=nowarn", str(patch)], root,
                        what=f"applying patch {patch.name}")
            applied.append(patch.name)
        context.env.update(entry["env"])
        context.cmake_options.update(entry["cmake_options"])
    context.details["patches"] = applied
    context.details["env"] = dict(context.env)
    _setup_ccache(target, context)
    context.details["compiler"] = _compiler_version(context)
    context.say(f"compiler: {context.details['compiler']}; jobs: {context.jobs}")
    for command in target.prebuild:
        context.run(command, root, shell=True, what="prebuild command")
    return root


def _in_range(repo, commit: str, entry: dict) -> bool:
    """Whether ``commit`` descends from (or is) ``from`` and does not descend from (nor is) ``before``."""
    def descends(ancestor: str) -> bool:
        sha = gitrepo.resolve(repo, ancestor).hexsha
        try:
            repo.git.merge_base("--is-ancestor", sha, commit)
            return True
        except git.GitCommandError as exc:
            if exc.status == 1:
                return False
            raise UserError(f"git merge-base {sha[:12]} {commit[:12]}: {exc.stderr.strip()}") from None

    if entry.get("from") and not descends(entry["from"]):
        return False
    return not (entry.get("before") and descends(entry["before"]))


def ccache_folder() -> Path:
    """The compiler cache shared by every build of every target: ``<workspace>/ccache``, or the folder
    ``HARNESS_CCACHE_DIR`` names (e.g. one cache for several workspaces of a CI machine)."""
    chosen = os.environ.get("HARNESS_CCACHE_DIR")
    return Path(chosen).expanduser().resolve() if chosen else workspace().home / "ccache"


def _setup_ccache(target: TargetDefinition, context: BuildContext) -> None:
    """Compile through ccache (cache in the workspace) unless the target says ``"ccache": false``.

    ``CCACHE_BASEDIR`` is the build folder, so paths below it are hashed relative: the same file in the build
    folders of two commits is the same cache entry.
    """
    wanted = target.ccache if target.ccache is not None else bool(shutil.which("ccache"))
    context.details["ccache"] = wanted
    if not wanted:
        context.say("ccache: off")
        return
    if not shutil.which("ccache"):
        raise UserError(f"{target.path}: $.ccache: true, but ccache is not installed: install it with "
                        "'sudo apt-get install ccache'")
    context.env.setdefault("CCACHE_DIR", str(ccache_folder()))
    context.env["CCACHE_BASEDIR"] = str(context.folder)
    if target.recipe == "cmake":
        context.cmake_options.setdefault("CMAKE_CXX_COMPILER_LAUNCHER", "ccache")
        context.cmake_options.setdefault("CMAKE_C_COMPILER_LAUNCHER", "ccache")
    elif Path("/usr/lib/ccache").is_dir():  # Debian's compiler names that call ccache
        context.env["PATH"] = "/usr/lib/ccache" + os.pathsep + context.environment().get("PATH", "")
    context.ccache_before = _ccache_counters(context)
    context.say(f"ccache: {context.env['CCACHE_DIR']} (base folder {context.folder})")


def _compiler_version(context: BuildContext) -> str:
    compiler = context.environment().get("CXX") or "c++"
    try:
        result = subprocess.run([compiler, "--version"], capture_output=True, text=True, timeout=30,
                                env=context.environment())
    except (OSError, subprocess.TimeoutExpired):
        return compiler
    return (result.stdout.splitlines() or [compiler])[0].strip()


def _install(target: TargetDefinition, produced: Path, context: BuildContext, made_by: str) -> list[str]:
    if not produced.is_file():
        raise UserError(f"{made_by} did not produce generated_executable {target.generated_executable!r}")
    (context.folder / "bin").mkdir(exist_ok=True)
    binary = context.folder / "bin" / target.name
    shutil.copy2(produced, binary)
    context.say(f"installed {produced} as {binary}")
    return [str(binary)]


_CCACHE_COUNTERS = ("direct_cache_hit", "preprocessed_cache_hit", "cache_miss")


def _ccache_counters(context: BuildContext) -> dict:
    result = subprocess.run(["ccache", "--print-stats"], capture_output=True, text=True, env=context.environment())
    stats = dict(line.split("\t", 1) for line in result.stdout.splitlines() if "\t" in line)
    return {k: int(v) for k, v in stats.items() if k in _CCACHE_COUNTERS and v.strip().isdigit()}


def _ccache_stats(context: BuildContext) -> None:
    """ccache's hits and misses during this build (in the details): the counters of the cache folder after
    the build minus those before (another build sharing the cache at the same time adds its own)."""
    if not context.details.get("ccache"):
        return
    before = context.ccache_before
    after = _ccache_counters(context)
    context.details["ccache_stats"] = {k: after.get(k, 0) - before.get(k, 0) for k in _CCACHE_COUNTERS}
    hits = context.details["ccache_stats"]["direct_cache_hit"] + context.details["ccache_stats"]["preprocessed_cache_hit"]
    context.say(f"ccache: {hits} hits, {context.details['ccache_stats']['cache_miss']} misses")


def _build_make(target: TargetDefinition, commit: str, folder: Path, context: BuildContext):
    """``configure`` commands, then ``make -jN <make_target> NAME=VALUE...`` in the exported source folder;
    the program is copied to bin/."""
    root = _prepare_source(target, commit, context)
    source = root / target.source_folder
    if not source.is_dir():
        raise UserError(f"source_folder {target.source_folder!r} does not exist at {commit[:12]}")
    for command in target.configure:
        context.run(command, source, shell=True, what="configure command")
    context.run(["make", f"-j{context.jobs}", target.make_target,
                 *(f"{name}={value}" for name, value in target.make_variables.items())], source)
    return _finish_native(target, source / target.generated_executable, root, context, "make")


def _build_cmake(target: TargetDefinition, commit: str, folder: Path, context: BuildContext):
    """``cmake -S <source_folder> -B build -DCMAKE_BUILD_TYPE=... -D...`` and ``cmake --build build -j N``;
    the program (``generated_executable`` in the build folder) is copied to bin/."""
    root = _prepare_source(target, commit, context)
    source = root / target.source_folder
    if not (source / "CMakeLists.txt").is_file():
        raise UserError(f"source_folder {target.source_folder!r} has no CMakeLists.txt at {commit[:12]}")
    build_dir = folder / "build"
    options = {"CMAKE_BUILD_TYPE": target.build_type, **context.cmake_options}
    context.details["cmake_options"] = options
    context.run(["cmake", "-S", str(source), "-B", str(build_dir),
                 *(f"-D{name}={value}" for name, value in options.items())], folder, what="cmake (configure)")
    targets = [arg for name in target.build_targets for arg in ("--target", name)]
    context.run(["cmake", "--build", str(build_dir), "--parallel", str(context.jobs), *targets], folder,
                what="cmake --build")
    return _finish_native(target, build_dir / target.generated_executable, root, context, "cmake --build")


def _finish_native(target: TargetDefinition, produced: Path, root: Path, context: BuildContext, made_by: str):
    """After a compiled build (make, cmake): the ccache counters, the program copied to bin/, the postbuild
    commands run in the source tree ``root``; the recipe's (executable, environment)."""
    _ccache_stats(context)
    executable = _install(target, produced, context, made_by)
    for command in target.postbuild:
        context.run(command, root, shell=True, what="postbuild command")
    return executable, {}


def _build_system(target: TargetDefinition, commit: str, folder: Path, context: BuildContext):
    """An installed program; its 'commit' is the sha256 of the binary, so an upgrade is a new build."""
    binary = _system_executable(target)
    context.log_file.write(f"system executable {binary} sha256 {commit}\n")
    return [str(binary)], {}


RECIPES = {"dem": _build_dem, "make": _build_make, "cmake": _build_cmake, "system": _build_system}
