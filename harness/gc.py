"""Reclaiming disk space in the workspace by a stated policy (``harness gc``).

Policy, per target and machine: the current build and the ``keep_builds`` most recent other builds (by
commit date) keep their build folders and their runs' folders. Removed: the folders of runs of older
builds, the folders of runs replaced by a run of newer test case content, and the build folders of older
builds. Store rows are never deleted: the runs stay listed with their results, states and consistency;
only their files go, and the run's ``folder`` is kept so the dashboard can say where they were.
Everything removed goes through ``Workspace.remove_tree``, which refuses paths outside the workspace.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from harness.workspace import workspace


@dataclass
class Collection:
    """What a collection removed (or would remove, in a dry run): paths and bytes."""

    run_folders: list[Path] = field(default_factory=list)
    build_folders: list[Path] = field(default_factory=list)
    bytes: int = 0


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
    from django.db.models import Q

    from harness.models import Build, Run

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
    runs = Run.objects.filter(build__in=builds).exclude(folder="")
    for run in runs.filter(Q(build_id__in=old) | Q(replaced=True)).order_by("pk"):
        _remove(Path(run.folder), out.run_folders, out, ws, dry_run)
    for build in builds:
        if build.pk not in keep and build.folder:
            _remove(Path(build.folder), out.build_folders, out, ws, dry_run)
    return out


def _remove(path: Path, bucket: list, out: Collection, ws, dry_run: bool) -> None:
    if not path.exists() or not ws.contains(path):
        return  # already gone, or an imported run whose files live elsewhere: never ours to delete
    out.bytes += _size(path)
    bucket.append(path)
    if not dry_run:
        ws.remove_tree(path)


def collect_profiles(dry_run: bool = False, machine: str | None = None) -> Collection:
    """Remove (or list) the raw samples (``perf.data``, ``harness.profiles``) of profiled runs that are not of
    a current build; their folded stacks (``profile.folded``, small) stay as long as the run folder does.

    Raw samples are what ``perf report`` needs and can be hundreds of MB; only the current build's are kept.
    Returned in ``run_folders``: the perf.data files removed.
    """
    from harness.models import Run
    from harness.profiles import PERF_DATA

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
