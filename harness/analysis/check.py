"""``harness check``: version consistency of a target's runs against its reference target, and JUnit XML.

Which runs get a verdict is ``harness.analysis.coverage``'s one rule: every selected run configuration of the
target's current build (broken ones failed with reason config, runs not executed failures of the gate unless
``allow_missing``). For every run of the target's current build
(``harness.execution.builds.record_current_build``: the build of the commit the revision resolves to now) at the test case content of now, the reference run is chosen by
``RunQuerySet.find_reference``: same test case, run name and content, by the reference target. A run
whose test case changed since it ran is stale (a failure: run it again); a reference run of other content is
never scored against, and is reported as stale. Results go to ``ConsistencyResult`` rows and
``Run.consistency`` / ``consistency_min``; the run's state becomes version-consistency-checked.

A reviewer's ``Override`` (whole run: blank quantity; or one quantity) accepts a failure or an
inconsistency: the JUnit report and the exit code honour it, the stored level stays what was computed.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from harness.adapters.base import UserError
from harness.analysis.consistency import QuantityResult, compare_runs, run_level
from harness.analysis.coverage import (
    covered_runs,
    earlier_content_run,
    record_build_failure,
    record_selection,
    selected,
)
from harness.execution.builds import failed_build, failure_message, record_current_build
from harness.report import junit
from harness.report.glossary import level_word
from harness.report.junit import provenance  # noqa: F401  (what a verdict was computed on; the dashboard shows it)
from harness.store.rules import WHOLE_RUN, gate_status, override_for, quantity_fails


@dataclass
class RunVerdict:
    """What a run amounts to for CI: ok, failed (with the reason) or skipped, and why."""

    run: object
    status: str                     # "passed", "failed", "skipped"
    message: str = ""
    kind: str = ""                  # failure reason or "inconsistent"
    results: list[QuantityResult] = field(default_factory=list)
    overridden: list[str] = field(default_factory=list)


@dataclass
class CheckReport:
    verdicts: list[RunVerdict] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)
    #: reference runs of other test case content than the runs they would be compared with
    stale_references: list[str] = field(default_factory=list)
    #: failed builds of the targets' revisions (``harness.execution.builds.failed_build``): one JUnit failure each
    failed_builds: list = field(default_factory=list)

    @property
    def failed(self) -> list[RunVerdict]:
        return [v for v in self.verdicts if v.status == "failed"]


def series_of(run) -> list[dict]:
    return [{"kind": s.kind, "name": s.name, "x_column": s.x_column, "columns": s.columns}
            for s in run.series.all()]


def _overrides(run) -> dict[str, str]:
    """override quantity ('' = whole run, ``harness.store.rules.WHOLE_RUN``) -> 'user: reason' of the reviewer's
    overrides."""
    out = {}
    for override in run.overrides.all():  # prefetched with their users by the callers that list many runs
        who = override.user.get_username() if override.user else "someone"
        out[override.quantity] = f"{who}: {override.reason}"
    return out


def check_run(run, reference_target: str | None) -> list[QuantityResult]:
    """Score one run against its reference run (same test case content) and store the results; [] when it
    cannot be checked."""
    # the store's models (Django) load once Django is set up (harness.store)
    from django.db import transaction

    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import ConsistencyResult, Run

    if run.state not in ("post_processed", "consistency_checked") or not reference_target:
        return []
    reference = Run.objects.find_reference(run, reference_target)
    if reference is None:
        run.consistency, run.consistency_min, run.reference_run = Run.Consistency.NO_REFERENCE, None, None
        run.state = Run.State.POST_PROCESSED
        run.save(update_fields=["consistency", "consistency_min", "reference_run", "state", "updated"])
        run.consistency_results.all().delete()
        return []
    results = compare_runs(series_of(run), series_of(reference), (run.config or {}).get("consistency"))
    level, lowest = run_level(results)
    with transaction.atomic():
        run.consistency_results.all().delete()
        ConsistencyResult.objects.bulk_create([
            ConsistencyResult(run=run, reference_run=reference, series_kind=r.series_kind,
                              series_name=r.series_name, quantity=r.quantity, value=r.value, level=r.level,
                              epsilon=r.epsilon, first_bad_step=r.first_bad_step, message=r.message)
            for r in results])
        run.consistency, run.consistency_min, run.reference_run = level, lowest, reference
        run.state = Run.State.CONSISTENCY_CHECKED
        run.save(update_fields=["consistency", "consistency_min", "reference_run", "state", "updated"])
    return results


def overruled(by: str, what: str) -> str:
    """How a verdict names an override (the glossary's "overruled"): reviewer and reason first, then what was
    overruled - ``alice: gravity raised on purpose - overruled ke (inconsistent)``. The CLI, JUnit and the
    dashboard print it as it is."""
    return f"{by} - overruled {what}"


def verdict_of(run, results: list[QuantityResult], has_reference_target: bool,
               allow_missing: bool = False) -> RunVerdict:
    """The verdict on one covered run (``harness.analysis.coverage``), its status by ``harness.store.rules.gate_status`` (a
    reviewer's override honoured by ``harness.store.rules.override_for``, as in ``harness.store.rules.is_accepted``), with
    the message that says why: the failure, the stale or not executed run (kind ``stale`` when a run of earlier test
    case content exists), the inconsistent quantities, and what reviewers accepted."""
    overrides = _overrides(run)
    whole = overrides.get(WHOLE_RUN)
    bad, overridden = [], []
    for r in results if run.state not in ("failed", "not_executed", "outdated") else ():
        if not quantity_fails(r.level):
            continue
        accepted = override_for(overrides, r.series_name, r.quantity)
        label = f"{r.series_name}:{r.quantity}" if r.series_kind != "thermo" else r.quantity
        if accepted:
            overridden.append(overruled(accepted, f"{label} ({level_word(r.level)})"))
            continue
        c = f"C = {r.value:.4g}" if r.value is not None else "no C"
        step = f", first bad step {r.first_bad_step:g}" if r.first_bad_step is not None else ""
        bad.append(f"{label}: {level_word(r.level)}, {c}{step}" + (f" ({r.message})" if r.message else ""))
    status = gate_status(run.state, bool(whole), bool(bad), allow_missing)
    if run.state == "failed":
        verdict = RunVerdict(run, status, f"{run.failure_reason}: {run.failure_message}", run.failure_reason)
        if whole:
            verdict.overridden = [overruled(whole, "the run's failure")]
        return verdict
    if run.state == "not_executed" and status == "failed":
        earlier = earlier_content_run(run)
        if earlier is not None:
            return RunVerdict(run, status, f"stale: the test case changed since this run (ran content "
                              f"{earlier.short_hash}, now {run.short_hash}); run 'harness run {run.target.name}' "
                              "again", "stale")
        return RunVerdict(run, status, f"not executed: run 'harness run {run.target.name}' (or pass "
                          "--allow-missing)", "not_executed")
    if status == "skipped":
        return RunVerdict(run, status, f"not run: {run.get_state_display()}")
    verdict = RunVerdict(run, status, results=results, overridden=overridden)
    if bad:
        verdict.kind, verdict.message = "inconsistent", "; ".join(bad)
    elif has_reference_target and run.consistency == "no_reference":
        verdict.message = "no reference run to compare with"
    return verdict


def check_targets(targets, machine: str, pattern: str | None = None, allow_missing: bool = False) -> CheckReport:
    """Check every selected run configuration of each target's current build at the test case content of
    now (``pattern``: only runs whose ``testcase/run`` match, as ``-k``): the store is first brought in line
    with the selection (``harness.analysis.coverage.record_selection``), then every covered run gets a verdict -
    broken configurations and runs not executed included. A target whose revision does not build: its runs
    are failed with reason build_failed, the build is in ``failed_builds`` and a problem."""
    # the store's models load once Django is set up (harness.store)
    from harness.store.models import Run

    report = CheckReport()
    for target in targets:
        build = record_current_build(target, machine)
        failed = failed_build(target, machine) if build is None else None
        if failed is not None:
            # the revision does not build: its selected runs are failures (build_failed), and the build is
            # the failing JUnit test case ``build`` of the target
            record_build_failure(target, failed, machine, pattern)
            report.failed_builds.append(failed)
            report.problems.append(failure_message(target.name, failed))
            report.verdicts += [verdict_of(run, [], bool(target.reference), allow_missing)
                                for run in covered_runs(build=failed, machine=machine)
                                if selected(pattern, run.testcase.path, run.name)]
            continue
        if build is None:
            report.problems.append(f"target {target.name!r} has no complete build of its revision "
                                   f"{target.revision!r} on machine {machine!r} "
                                   f"(run 'harness build {target.name}' or 'harness run {target.name}')")
            continue
        record_selection(target, build, machine, pattern)
        every = list(covered_runs(build=build, machine=machine))
        runs = [run for run in every if selected(pattern, run.testcase.path, run.name)]
        if not every:
            report.problems.append(f"target {target.name!r}: no runs of its current build {build.commit[:12]} "
                                   f"on machine {machine!r} (run 'harness run {target.name}')")
        stale_before = len(report.stale_references)
        for run in runs:
            results = check_run(run, target.reference)
            if target.reference and run.consistency == "no_reference":
                stale = Run.objects.stale_reference(run, target.reference)
                if stale is not None:
                    report.stale_references.append(
                        f"{target.reference} {run.testcase.path}/{run.name} at {stale.build.commit[:10]} ran test "
                        f"case content {stale.short_hash}, not {run.short_hash}")
            report.verdicts.append(verdict_of(run, results, bool(target.reference), allow_missing))
        stale_count = len(report.stale_references) - stale_before
        if stale_count:
            report.problems.append(f"{stale_count} reference run(s) of {target.reference!r} are "
                                   f"stale (other test case content); run 'harness run {target.reference}' to "
                                   "refresh them")
    return report


def junit_xml(report: CheckReport) -> str:
    """JUnit XML of a check (``harness.report.junit``, the writer the dashboard uses too)."""
    return junit.junit_xml(report.verdicts, report.failed_builds)


def write_junit(report: CheckReport, path: Path) -> None:
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(junit_xml(report), encoding="utf-8")
    except OSError as exc:
        raise UserError(f"--junit {path}: cannot write ({exc.strerror})") from None
