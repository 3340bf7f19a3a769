"""Reclaiming disk space in the workspace by a stated policy (``harness gc``).

Policy, per target and machine: the current build and the ``keep_builds`` most recent other builds (by
commit date) keep their build folders and their runs' folders. Removed: the folders of runs of older
builds, the folders of runs replaced by a run of newer test case content, and the build folders of older
builds. Store rows are never deleted: the runs stay listed with their results, states and consistency;
only their files go, and the run's ``folder`` is kept so the dashboard can say where they were.
Everything removed goes through ``Workspace.remove_tree``, which refuses paths outside the workspace.

Nothing another process holds is removed: a build whose use lock (``Workspace.use_lock``, held shared by
every ``harness run`` using the build, from planning until its runs are stored) or build lock is held, and a
run folder whose run lock (``harness.execution.scheduler``) is held, are skipped and reported. gc holds the locks it took
while it removes, so no run of that build can start meanwhile.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from pathlib import Path

from filelock import Timeout

from harness.execution.profiles import PERF_DATA
from harness.execution.workspace import workspace


@dataclass
class Collection:
    """What a collection removed (or would remove, in a dry run): paths and bytes."""

    run_folders: list[Path] = field(default_factory=list)
    build_folders: list[Path] = field(default_factory=list)
    bytes: int = 0
    #: what another harness process holds, left in place: "path (why)"
    skipped: list[str] = field(default_factory=list)


def _size(path: Path) -> int:
    if path.is_symlink() or path.is_file():
        return path.lstat().st_size
    return sum(p.lstat().st_size for p in path.rglob("*") if p.is_file() and not p.is_symlink())


def kept_builds(builds, keep_builds: int) -> set[int]:
    """Ids of the builds to keep among one target's builds on one machine."""
    ordered = sorted(builds, key=lambda b: (b.committed_at is not None, b.committed_at or b.finished,
                                            b.finished is not None, b.finished, b.pk), reverse=True)
    keep = {b.pk for b in ordered if b.current}
    keep |= {b.pk for b in [b for b in ordered if not b.current][:max(0, keep_builds)]}
    return keep


def collect(keep_builds: int = 2, dry_run: bool = False, machine: str | None = None) -> Collection:
    """Remove (or, with ``dry_run``, list) the folders the policy lets go; ``machine`` limits it to one."""
    # the store's models (Django) load once Django is set up (harness.store)
    from django.db.models import Q

    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Build, Run

    ws = workspace()
    out = Collection()
    builds = Build.objects.select_related("target", "machine")
    if machine:
        builds = builds.filter(machine__name=machine)
    groups: dict = {}
    for build in builds:
        groups.setdefault((build.target_id, build.machine_id), []).append(build)
    keep: set[int] = set()
    for group in groups.values():
        keep |= kept_builds(group, keep_builds)
    old = [b.pk for b in builds if b.pk not in keep]
    runs = Run.objects.filter(build__in=builds).exclude(folder="").select_related("build", "target")
    held: list = []
    in_use: dict[int, bool] = {}

    def free(build) -> bool:
        """Whether no other process uses ``build``; its locks are then held by gc until the end."""
        if build.pk not in in_use:
            use = ws.use_lock(build.target.name, build.key)
            building = ws.lock(f"build-{build.target.name}-{build.key}", timeout=0)
            ok = use.acquire(exclusive=True, blocking=False)
            if ok:
                held.append(use)
                ok = _try(building)
                if ok:
                    held.append(building)
            in_use[build.pk] = not ok
        return not in_use[build.pk]

    try:
        for run in runs.filter(Q(build_id__in=old) | Q(replaced=True)).order_by("pk"):
            path = Path(run.folder)
            if not path.exists() or not ws.contains(path):
                continue
            if not free(run.build):
                out.skipped.append(f"{path} (its build {run.target.name} {run.build.key} is in use by another "
                                   "harness process)")
                continue
            lock = _run_lock(ws, run.folder)
            if not _try(lock):
                out.skipped.append(f"{path} (another harness process is running it)")
                continue
            held.append(lock)
            _remove(path, out.run_folders, out, ws, dry_run)
        for build in builds:
            if build.pk not in keep and build.folder and Path(build.folder).exists():
                if not free(build):
                    out.skipped.append(f"{build.folder} (build in use by another harness process)")
                    continue
                _remove(Path(build.folder), out.build_folders, out, ws, dry_run)
    finally:
        for lock in reversed(held):
            lock.release()
    return out


def _run_lock(ws, folder: str):
    """The lock ``harness run`` holds on a run folder while it runs it (``harness.execution.scheduler._run_lock``)."""

    return ws.lock(f"run-{hashlib.sha1(folder.encode()).hexdigest()[:20]}", timeout=0)


def _try(lock) -> bool:

    try:
        lock.acquire(timeout=0)
    except Timeout:
        return False
    return True


def _remove(path: Path, bucket: list, out: Collection, ws, dry_run: bool) -> None:
    if not path.exists() or not ws.contains(path):
        return  # already gone, or an imported run whose files live elsewhere: never ours to delete
    out.bytes += _size(path)
    bucket.append(path)
    if not dry_run:
        ws.remove_tree(path)


def collect_profiles(dry_run: bool = False, machine: str | None = None) -> Collection:
    """Remove (or list) the raw samples (``perf.data``, ``harness.execution.profiles``) of profiled runs that are not of
    a current build; their folded stacks (``profile.folded``, small) stay as long as the run folder does.

    Raw samples are what ``perf report`` needs and can be hundreds of MB; only the current build's are kept.
    Returned in ``run_folders``: the perf.data files removed.
    """
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Run

    ws = workspace()
    out = Collection()
    runs = Run.objects.exclude(profile="").exclude(folder="").filter(build__current=False)
    if machine:
        runs = runs.filter(machine__name=machine)
    for folder in runs.values_list("folder", flat=True).order_by("pk"):
        path = Path(folder) / PERF_DATA
        if path.is_file() and ws.contains(path):
            out.bytes += path.stat().st_size
            out.run_folders.append(path)
            if not dry_run:
                ws.remove_tree(path)
    return out
