"""Run records: the JSON file in each run folder and its mirror in the store.

``store_record`` writes a record (from ``execute`` or read back from ``run.json``) into the store;
``import_folder`` finds every ``run.json`` below a folder, so runs made on another machine (and copied
over) join the store under that machine's name. An imported record is validated first
(``harness.store.runrecord.validate``), and one that differs from a stored run of the same identity (machine,
target build, test case and its content, run name) is a conflict: reported and left out unless
``replace`` is asked for, so that an edited copy of a record can never silently turn a failure into a pass.
"""
from __future__ import annotations

import json
from datetime import datetime
from pathlib import Path

from harness.store import runrecord
from harness.analysis.breakdown import from_timing as breakdown_from_timing
from harness.adapters.base import UserError
from harness.store.rules import SUCCESS_STATES
from harness.store.runrecord import RECORD_FILE, RunRecord, finite


def _when(value):
    if not value:
        return None
    return datetime.fromisoformat(value) if isinstance(value, str) else value


def store_record(record: RunRecord, imported: bool = False, only_new: bool = False):
    """Create or update the Run (and its machine, target, build, test case, series) a record describes.

    ``only_new``: store it only when no run of that identity is stored yet (the stored one is returned as it
    is); a run another process stores at the same moment wins (``harness.analysis.coverage``)."""
    # the store's models (Django) load once Django is set up (harness.store)
    from django.db import IntegrityError

    if only_new:
        try:
            return _store(record, imported, only_new)
        except IntegrityError:  # inserted meanwhile by another process (PostgreSQL's unique constraint)
            return None
    return _store(record, imported, only_new)


def _store(record: RunRecord, imported: bool, only_new: bool):
    # the store's models (Django) load once Django is set up (harness.store)
    from django.db import transaction

    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Build, Machine, Run, Series, Target, TestCase

    with transaction.atomic():
        machine = Machine.objects.get_or_create(name=record.machine)[0]
        target, created = Target.objects.get_or_create(name=record.target)
        definition = record.target_definition
        if created or not target.definition:
            target.definition = definition
            if definition.get("reference"):
                target.reference = Target.objects.get_or_create(name=definition["reference"])[0]
            target.save()
        info = record.build
        build = Build.objects.filter(target=target, machine=machine, commit=info.get("commit", ""),
                                     definition_hash=info.get("definition_hash", "")).first()
        if build is None:
            build = Build.objects.create(
                target=target, machine=machine, commit=info.get("commit", ""),
                definition_hash=info.get("definition_hash", ""), revision=info.get("revision", ""),
                committed_at=_when(info.get("committed_at")), commit_message=info.get("commit_message", ""),
                status=Build.Status.COMPLETE, executable=json.dumps(info.get("executable") or []),
                environment=info.get("environment") or {}, folder=info.get("folder", ""),
                finished=_when(record.started))
            _adopt_imported_build(build)
        testcase = TestCase.objects.get_or_create(path=record.testcase)[0]
        content = record.testcase_hash
        if only_new:
            stored = Run.objects.filter(machine=machine, build=build, testcase=testcase, name=record.run,
                                        testcase_hash=content).first()
            if stored is not None and not stored.replaced:
                return stored  # a replaced (outdated) run of this content comes back as not executed
        fields = dict(
            target=target, state=record.state, failure_reason=record.failure_reason,
            failure_message=record.failure_message, config=finite(record.config),
            folder=record.folder, command=record.command,
            exit_code=record.exit_code, started=_when(record.started),
            finished=_when(record.finished), wall_time=finite(record.wall_time),
            stepping_time=_stepping_time(record),
            # a record written before breakdowns existed: its timing's sections (as migration 0005 fills them)
            timing=finite(record.timing),
            breakdown=finite(record.breakdown) or breakdown_from_timing(finite(record.timing)),
            profile=record.profile, warning_count=record.warning_count,
            consistency="", consistency_min=None, reference_run=None, replaced=False)
        run, _ = Run.objects.update_or_create(machine=machine, build=build, testcase=testcase,
                                              name=record.run, testcase_hash=content, defaults=fields)
        # the same run of earlier (or other) test case content is kept, with its folder, as outdated
        (Run.objects.filter(machine=machine, build=build, testcase=testcase, name=record.run)
         .exclude(pk=run.pk).exclude(state=Run.State.OUTDATED, replaced=True)
         .update(state=Run.State.OUTDATED, replaced=True))
        if imported and not build.current and run.state != Run.State.OUTDATED:
            # a record of a build that is not its target's current one (imported from an older revision)
            run.state = Run.State.OUTDATED
            run.save(update_fields=["state"])
        run.consistency_results.all().delete()
        run.series.all().delete()
        Series.objects.bulk_create([
            Series(run=run, kind=s["kind"], name=s["name"], x_column=s.get("x_column", ""),
                   columns=s.get("columns", {}), meta=s.get("meta", {}))
            for s in finite(record.series)])
    return run


def _stepping_time(record: RunRecord) -> float | None:
    """The record's stepping time; a record written before it existed: from its timing."""
    if "stepping_time" in record.model_fields_set or not record.timing:
        return finite(record.stepping_time)
    return runrecord.stepping_time_of(record.timing)


def _adopt_imported_build(build) -> None:
    """A build first seen in an imported record becomes its machine's current build of the target when
    that machine has none yet or only one of an older commit (the other machine resolved the revision,
    not this one; its newest commit is the best guess of what it runs now)."""
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.execution.builds import make_current
    from harness.store.models import Build

    current = Build.objects.filter(target_id=build.target_id, machine_id=build.machine_id, current=True).first()
    if current is None or (build.committed_at and current.committed_at and build.committed_at > current.committed_at):
        make_current(build)


def read_record(path: Path) -> RunRecord:
    """A run record from ``path``, validated; a UserError naming the file and field otherwise."""
    try:
        data = runrecord.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise UserError(f"{path}: not a run record ({exc})") from None
    problems = [f"{problem.where()}: {problem.message}" for problem in runrecord.validate(data)]
    if problems:
        raise UserError(f"{path}: not a valid run record: {'; '.join(problems[:3])}"
                        + (f" (and {len(problems) - 3} more)" if len(problems) > 3 else ""))
    return RunRecord.model_validate(data)


def _comparable_state(state: str, run=None) -> str:
    """States that mean the same result: a checked run was post-processed; an outdated one what it was."""
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.rules import effective_state

    if run is not None:
        state = effective_state(run)
    return "post_processed" if state == "consistency_checked" else state


def _series_key(items) -> str:
    return json.dumps(sorted([s["kind"], s["name"], s.get("columns", {})] for s in items), sort_keys=True)


def conflict(record: RunRecord):
    """How a record differs from the stored run of the same identity ('' when it does not, or none exists)."""
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Run

    build = record.build
    run = Run.objects.filter(machine__name=record.machine, target__name=record.target,
                             build__commit=build.get("commit", ""),
                             build__definition_hash=build.get("definition_hash", ""),
                             testcase__path=record.testcase, name=record.run,
                             testcase_hash=record.testcase_hash).first()
    if run is None:
        return ""
    mine = {"state": _comparable_state(run.state, run), "failure_reason": run.failure_reason,
            "failure_message": run.failure_message, "exit_code": run.exit_code,
            "started": run.started, "finished": run.finished, "wall_time": run.wall_time}
    theirs = {"state": _comparable_state(record.state), "failure_reason": record.failure_reason,
              "failure_message": record.failure_message, "exit_code": record.exit_code,
              "started": _when(record.started), "finished": _when(record.finished),
              "wall_time": finite(record.wall_time)}
    differ = [key for key in mine if mine[key] != theirs[key]]
    if not differ:
        stored = [{"kind": s.kind, "name": s.name, "columns": s.columns} for s in run.series.all()]
        if _series_key(stored) != _series_key(finite(record.series)):
            differ.append("series")
    if not differ:
        return ""
    key = differ[0]
    detail = f" ({mine[key]!s:.40} stored, {theirs[key]!s:.40} imported)" if key in mine else ""
    return f"differs from the stored run #{run.pk} in {', '.join(differ)}{detail}"


def import_folder(folder: Path, machine: str | None = None, replace: bool = False) -> tuple[list, list[str]]:
    """Store every valid run record below ``folder``; ``machine`` overrides the recorded machine name.

    The record's folder is set to where the run folder is now. Returns (stored runs, problems): a record
    that does not validate, or conflicts with a stored one (unless ``replace``), is a problem and skipped.
    """
    # the store's models (Django) load once Django is set up (harness.store)
    from django.db import DatabaseError

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
        record.folder = str(path.parent.resolve())
        if machine:
            record.machine = machine
        where = runrecord.null_values(record)
        if where and record.state in SUCCESS_STATES:
            # a success holding non-finite values is what this harness fails as non_finite (harness.execution.execute)
            record.fail("non_finite", f"imported with non-finite (null) values in {where}")
            problems.append(f"{path}: $.series: non-finite (null) values in {where}; imported as failed "
                            "(non_finite)")
        differs = conflict(record)
        if differs and not replace:
            problems.append(f"{path}: conflict: {differs}; not imported (--replace to replace the stored run)")
            continue
        try:
            runs.append(store_record(record, imported=True))
        except DatabaseError as exc:  # what the store refuses is this record's problem, not the others'
            problems.append(f"{path}: the store refused it: {str(exc).strip().splitlines()[0][:200]}")
    return runs, problems
