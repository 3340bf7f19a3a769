"""Building targets (thesis 4.2): resolve the revision, export the source, run the recipe, cache the result.

Builds are cached in ``<workspace>/builds/<target>/<commit>-<definition hash>/`` and count only once the
recipe finished and the ``done`` marker is written (a crash mid-build leaves no half build that looks
usable). The build log is kept as ``build.log`` and in the store. The current build of a target is the one
of the commit its revision resolves to now (``current_build``); the results of its other builds are
outdated (thesis 4.3.4) but kept, with their run folders.
"""
from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys
from datetime import datetime, timezone
from pathlib import Path

from filelock import Timeout

from harness import gitrepo
from harness.adapters.base import UserError
from harness.targets import TargetDefinition
from harness.workspace import workspace

DONE_MARKER = "done"


class BuildError(UserError):
    """A recipe failed; the message names the target and points at the kept log."""


def _now():
    return datetime.now(timezone.utc)


def ensure_machine(name: str):
    from harness.models import Machine

    return Machine.objects.get_or_create(name=name)[0]


def ensure_target(target: TargetDefinition):
    """The store's row for a target definition (created or updated), linked to its reference's row."""
    from harness.models import Target

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
    except those a newer run of the same test case content replaced (``harness.records.store_record``).
    """
    from django.db import transaction

    from harness.models import Build, Run
    from harness.rules import restored_state

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
    from harness.models import Build

    info = info or resolve_commit(target)
    return Build.objects.filter(target__name=target.name, machine__name=machine_name, commit=info["commit"],
                                definition_hash=target.definition_hash, status=Build.Status.COMPLETE).first()


def current_build(target, machine_name: str):
    """The current build of a target on a machine, or None when that commit is not built here.

    With a definition (``TargetDefinition``) the revision is resolved now and the result recorded with
    ``make_current``; with only a name (store-only targets, the dashboard) the recorded current build.
    ``build``, ``run``, ``check``, ``status``, ``sweep``, ``list`` and the dashboard all ask this. A
    revision given on the command line (``TARGET@REV``) names its build without making it current.
    """
    from harness.models import Build

    if isinstance(target, TargetDefinition):
        build = find_build(target, machine_name)
        if build is not None and not target.explicit_revision:
            make_current(build)
        return build
    return Build.objects.filter(target__name=target, machine__name=machine_name, current=True,
                                status=Build.Status.COMPLETE).first()


def build_target(target: TargetDefinition, machine_name: str, force: bool = False, log=None):
    """Build ``target`` at its revision on this machine, or return the cached build; it becomes current
    unless the revision was given on the command line (``TARGET@REV``).

    ``log`` is a callable taking a line of progress text (default: nothing). Two processes building the
    same target and commit wait for each other (a lock per build folder) and build it once.
    Raises BuildError when the recipe fails (the Build row is kept with status failed and the log).
    """
    from harness.models import Build, Run

    say = log or (lambda text: None)
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
        if not (build.status == Build.Status.COMPLETE and not force and (folder / DONE_MARKER).is_file()):
            _run_recipe(target, build, info, folder, say)
            if force:
                # a forced rebuild replaces the binary of this commit too: its results are outdated
                build.runs.exclude(state=Run.State.OUTDATED).update(state=Run.State.OUTDATED, replaced=True)
        if not target.explicit_revision:
            make_current(build)
        return build
    finally:
        lock.release()


def _run_recipe(target: TargetDefinition, build, info: dict, folder: Path, say) -> None:
    from harness.models import Build

    say(f"building {target.name} at {info['commit'][:12]} ({target.recipe})")
    workspace().fresh_folder(folder)
    build.revision = target.revision
    build.committed_at = datetime.fromisoformat(info["committed_at"]) if info["committed_at"] else None
    build.commit_message = info["commit_message"]
    build.status = Build.Status.BUILDING
    build.folder = str(folder)
    build.started, build.finished, build.log = _now(), None, ""
    build.save()
    log_path = folder / "build.log"
    try:
        with open(log_path, "w", encoding="utf-8") as log_file:
            executable, environment = RECIPES[target.recipe](target, info["commit"], folder, log_file)
    except UserError as exc:
        build.status = Build.Status.FAILED
        build.log = _read_text(log_path) + f"\n{exc}\n"
        build.finished = _now()
        build.save()
        tail = "\n".join(build.log.strip().splitlines()[-15:])
        raise BuildError(f"build of target {target.name!r} at {info['commit'][:12]} failed: {exc} "
                         f"(log: {log_path})\n{tail}") from None
    (folder / DONE_MARKER).write_text(json.dumps({"commit": info["commit"], "executable": executable}))
    build.status = Build.Status.COMPLETE
    build.executable = json.dumps(executable)
    build.environment = environment
    build.log = _read_text(log_path)
    build.finished = _now()
    build.save()


def _read_text(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return ""


def _build_dem(target: TargetDefinition, commit: str, folder: Path, log_file):
    """The bundled engine: ``engine/`` exported at the commit, run as ``python -m engine``."""
    repo = gitrepo.open_repository(target.repository)
    source = gitrepo.export(repo, commit, target.source_folder, folder / "src")
    log_file.write(f"exported {target.source_folder} at {commit} from {target.repository} to {source}\n")
    package = source.name
    if not (source / "__main__.py").is_file():
        raise UserError(f"{target.source_folder}/__main__.py does not exist at {commit[:12]}: not a runnable engine")
    return [sys.executable, "-m", package], {"PYTHONPATH": str(folder / "src")}


def _build_make(target: TargetDefinition, commit: str, folder: Path, log_file):
    """``make <make_target> NAME=VALUE...`` in the exported source folder; the program is copied to bin/."""
    repo = gitrepo.open_repository(target.repository)
    gitrepo.export(repo, commit, ".", folder / "src")
    source = folder / "src" / target.source_folder
    if not source.is_dir():
        raise UserError(f"source_folder {target.source_folder!r} does not exist at {commit[:12]}")
    command = ["make", f"-j{target.make_jobs}", target.make_target,
               *(f"{name}={value}" for name, value in target.make_variables.items())]
    log_file.write(f"$ cd {source} && {' '.join(command)}\n")
    log_file.flush()
    result = subprocess.run(command, cwd=source, stdout=log_file, stderr=subprocess.STDOUT,
                            stdin=subprocess.DEVNULL)
    if result.returncode != 0:
        raise UserError(f"make exited with code {result.returncode}")
    produced = source / target.generated_executable
    if not produced.is_file():
        raise UserError(f"make did not produce generated_executable {target.generated_executable!r}")
    (folder / "bin").mkdir()
    binary = folder / "bin" / target.name
    shutil.copy2(produced, binary)
    log_file.write(f"installed {produced} as {binary}\n")
    return [str(binary)], {}


def _build_system(target: TargetDefinition, commit: str, folder: Path, log_file):
    """An installed program; its 'commit' is the sha256 of the binary, so an upgrade is a new build."""
    binary = _system_executable(target)
    log_file.write(f"system executable {binary} sha256 {commit}\n")
    return [str(binary)], {}


RECIPES = {"dem": _build_dem, "make": _build_make, "system": _build_system}


def build_environment(build) -> dict:
    """The process environment to run a build's executable in."""
    env = dict(os.environ)
    env.update(build.environment or {})
    return env
