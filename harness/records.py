"""Run records: the JSON file in each run folder and its mirror in the store.

``store_record`` writes a record (from ``execute`` or read back from ``run.json``) into the store;
``import_folder`` finds every ``run.json`` below a folder, so runs made on another machine (and copied
over) join the store under that machine's name.
"""
from __future__ import annotations

import json
from datetime import datetime
from pathlib import Path

from harness.adapters.base import UserError
from harness.execute import RECORD_FILE


def _when(value):
    if not value:
        return None
    return datetime.fromisoformat(value) if isinstance(value, str) else value


def store_record(record: dict):
    """Create or update the Run (and its machine, target, build, test case, series) a record describes."""
    from django.db import transaction

    from harness.models import Build, Machine, Run, Series, Target, TestCase

    with transaction.atomic():
        machine = Machine.objects.get_or_create(name=record["machine"])[0]
        target, created = Target.objects.get_or_create(name=record["target"])
        definition = record.get("target_definition") or {}
        if created or not target.definition:
            target.definition = definition
            if definition.get("reference"):
                target.reference = Target.objects.get_or_create(name=definition["reference"])[0]
            target.save()
        info = record.get("build") or {}
        build = Build.objects.filter(target=target, machine=machine, commit=info.get("commit", ""),
                                     definition_hash=info.get("definition_hash", "")).first()
        if build is None:
            build = Build.objects.create(
                target=target, machine=machine, commit=info.get("commit", ""),
                definition_hash=info.get("definition_hash", ""), revision=info.get("revision", ""),
                committed_at=_when(info.get("committed_at")), commit_message=info.get("commit_message", ""),
                status=Build.Status.COMPLETE, executable=json.dumps(info.get("executable") or []),
                environment=info.get("environment") or {}, folder=info.get("folder", ""),
                finished=_when(record.get("started")))
            _adopt_imported_build(build)
        testcase = TestCase.objects.get_or_create(path=record["testcase"])[0]
        content = record.get("testcase_hash") or ""
        fields = dict(
            target=target, state=record["state"], failure_reason=record.get("failure_reason", ""),
            failure_message=record.get("failure_message", ""), config=record.get("config") or {},
            folder=record.get("folder", ""), command=record.get("command") or [],
            exit_code=record.get("exit_code"), started=_when(record.get("started")),
            finished=_when(record.get("finished")), wall_time=record.get("wall_time"),
            timing=record.get("timing") or {}, warning_count=record.get("warning_count", 0),
            consistency="", consistency_min=None, reference_run=None, replaced=False)
        run, _ = Run.objects.update_or_create(machine=machine, build=build, testcase=testcase,
                                              name=record["run"], testcase_hash=content, defaults=fields)
        # the same run of earlier (or other) test case content is kept, with its folder, as outdated
        (Run.objects.filter(machine=machine, build=build, testcase=testcase, name=record["run"])
         .exclude(pk=run.pk).exclude(state=Run.State.OUTDATED, replaced=True)
         .update(state=Run.State.OUTDATED, replaced=True))
        run.consistency_results.all().delete()
        run.series.all().delete()
        Series.objects.bulk_create([
            Series(run=run, kind=s["kind"], name=s["name"], x_column=s.get("x_column", ""),
                   columns=s.get("columns", {}), meta=s.get("meta", {}))
            for s in record.get("series", [])])
    return run


def _adopt_imported_build(build) -> None:
    """A build first seen in an imported record becomes its machine's current build of the target when
    that machine has none yet or only one of an older commit (the other machine resolved the revision,
    not this one; its newest commit is the best guess of what it runs now)."""
    from harness.builds import make_current
    from harness.models import Build

    current = Build.objects.filter(target_id=build.target_id, machine_id=build.machine_id, current=True).first()
    if current is None or (build.committed_at and current.committed_at and build.committed_at > current.committed_at):
        make_current(build)


def read_record(path: Path) -> dict:
    try:
        record = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise UserError(f"{path}: not a run record ({exc})") from None
    missing = [key for key in ("machine", "target", "testcase", "run", "state") if key not in record]
    if not isinstance(record, dict) or missing:
        raise UserError(f"{path}: not a run record (missing {', '.join(missing)})")
    return record


def import_folder(folder: Path, machine: str | None = None) -> tuple[list, list[str]]:
    """Store every run record below ``folder``; ``machine`` overrides the recorded machine name.

    The record's folder is set to where the run folder is now.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise UserError(f"{folder}: not a folder")
    runs, problems = [], []
    for path in sorted(folder.rglob(RECORD_FILE)):
        try:
            record = read_record(path)
        except UserError as exc:
            problems.append(str(exc))
            continue
        record["folder"] = str(path.parent.resolve())
        if machine:
            record["machine"] = machine
        runs.append(store_record(record))
    return runs, problems
