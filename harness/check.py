"""``harness check``: version consistency of a target's runs against its reference target, and JUnit XML.

For every run of the target's current build (the newest complete build on this machine) the reference run
is the reference target's run of the same test case and run name (its current build first, then any
successful run on this machine, then on any machine). Results go to ``ConsistencyResult`` rows and
``Run.consistency`` / ``consistency_min``; the run's state becomes version-consistency-checked.

A reviewer's ``Override`` (whole run: blank quantity; or one quantity) accepts a failure or an
inconsistency: the JUnit report and the exit code honour it, the stored level stays what was computed.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from harness.adapters.base import UserError
from harness.builds import current_build
from harness.consistency import FAILING_LEVELS, QuantityResult, compare_runs, run_level

SUCCESS_STATES = ("executed", "post_processed", "consistency_checked")


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

    @property
    def failed(self) -> list[RunVerdict]:
        return [v for v in self.verdicts if v.status == "failed"]


def series_of(run) -> list[dict]:
    return [{"kind": s.kind, "name": s.name, "x_column": s.x_column, "columns": s.columns}
            for s in run.series.all()]


def find_reference_run(run, reference_target: str):
    from harness.models import Run

    candidates = (Run.objects.filter(target__name=reference_target, testcase=run.testcase, name=run.name,
                                     state__in=SUCCESS_STATES).order_by("-finished", "-id"))
    build = current_build(reference_target, run.machine.name)
    for queryset in (candidates.filter(build=build) if build else candidates.none(),
                     candidates.filter(machine=run.machine), candidates):
        found = queryset.first()
        if found is not None:
            return found
    return None


def _overrides(run) -> dict[str, str]:
    """quantity ('' = whole run) -> 'user: reason' of the reviewer's overrides."""
    out = {}
    for override in run.overrides.all().select_related("user"):
        who = override.user.get_username() if override.user else "someone"
        out[override.quantity] = f"{who}: {override.reason}"
    return out


def _quantity_keys(result) -> tuple[str, ...]:
    return (result.quantity, f"{result.series_name}:{result.quantity}", f"{result.series_name}.{result.quantity}")


def check_run(run, reference_target: str | None) -> list[QuantityResult]:
    """Score one run against its reference run and store the results; [] when it cannot be checked."""
    from django.db import transaction

    from harness.models import ConsistencyResult, Run

    if run.state not in ("post_processed", "consistency_checked") or not reference_target:
        return []
    reference = find_reference_run(run, reference_target)
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


def verdict_of(run, results: list[QuantityResult], has_reference_target: bool) -> RunVerdict:
    overrides = _overrides(run)
    whole = overrides.get("")
    if run.state == "failed":
        verdict = RunVerdict(run, "failed", f"{run.failure_reason}: {run.failure_message}", run.failure_reason)
        if whole:
            verdict.status, verdict.overridden = "passed", [f"run failure accepted by {whole}"]
        return verdict
    if run.state in ("not_executed", "outdated"):
        return RunVerdict(run, "skipped", f"run {run.get_state_display()}")
    verdict = RunVerdict(run, "passed", results=results)
    bad = []
    for r in results:
        if r.level not in FAILING_LEVELS:
            continue
        accepted = whole or next((overrides[k] for k in _quantity_keys(r) if k in overrides), None)
        label = f"{r.series_name}:{r.quantity}" if r.series_kind != "thermo" else r.quantity
        if accepted:
            verdict.overridden.append(f"{label} ({r.level}) accepted by {accepted}")
            continue
        c = f"C = {r.value:.4g}" if r.value is not None else "no C"
        step = f", first bad step {r.first_bad_step:g}" if r.first_bad_step is not None else ""
        bad.append(f"{label}: {r.level}, {c}{step}" + (f" ({r.message})" if r.message else ""))
    if bad:
        verdict.status, verdict.kind = "failed", "inconsistent"
        verdict.message = "; ".join(bad)
    elif has_reference_target and run.consistency == "no_reference":
        verdict.message = "no reference run to compare with"
    return verdict


def check_targets(targets, machine: str) -> CheckReport:
    """Check every run of each target's current build; failed runs are reported too."""
    from harness.models import Run

    report = CheckReport()
    for target in targets:
        build = current_build(target.name, machine)
        if build is None:
            report.problems.append(f"target {target.name!r} has no complete build on machine {machine!r} "
                                   f"(run 'harness build {target.name}' or 'harness run {target.name}')")
            continue
        runs = (Run.objects.filter(build=build, machine__name=machine).select_related("testcase", "machine",
                                                                                      "target")
                .order_by("testcase__path", "name"))
        if not runs.exists():
            report.problems.append(f"target {target.name!r}: no runs of its current build {build.commit[:12]} "
                                   f"on machine {machine!r} (run 'harness run {target.name}')")
        for run in runs:
            results = check_run(run, target.reference)
            report.verdicts.append(verdict_of(run, results, bool(target.reference)))
    return report


def _log_tail(run) -> str:
    record = Path(run.folder or "/nonexistent") / "run.json"
    try:
        data = json.loads(record.read_text(encoding="utf-8"))
        return data.get("log_tail", "")
    except (OSError, ValueError):
        return ""


def junit_xml(report: CheckReport) -> str:
    """JUnit XML for Jenkins: a suite per target and test case folder, a test per run."""
    from junit_xml import TestCase, TestSuite, to_xml_report_string

    suites: dict[tuple[str, str], list] = {}
    for verdict in report.verdicts:
        run = verdict.run
        classname = f"{run.target.name}.{run.testcase.path.replace('/', '.')}"
        case = TestCase(run.name, classname=classname, elapsed_sec=run.wall_time or 0.0,
                        stdout=_log_tail(run), timestamp=run.started.isoformat() if run.started else None)
        notes = []
        if verdict.results:
            lowest = min((r.value for r in verdict.results if r.value is not None), default=None)
            notes.append(f"consistency {run.consistency}" + (f", lowest C = {lowest:.4g}" if lowest is not None
                                                              else ""))
        notes += [f"overridden: {text}" for text in verdict.overridden]
        if verdict.message and verdict.status != "failed":
            notes.append(verdict.message)
        if notes:
            case.stdout = "\n".join(notes) + ("\n--- log tail ---\n" + case.stdout if case.stdout else "")
        if verdict.status == "failed":
            case.add_failure_info(message=verdict.message[:2000], output=verdict.message,
                                  failure_type=verdict.kind or "failure")
        elif verdict.status == "skipped":
            case.add_skipped_info(message=verdict.message)
        suites.setdefault((run.target.name, run.testcase.path), []).append(case)
    return to_xml_report_string([TestSuite(f"{target}/{path}", cases) for (target, path), cases in suites.items()])


def write_junit(report: CheckReport, path: Path) -> None:
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(junit_xml(report), encoding="utf-8")
    except OSError as exc:
        raise UserError(f"--junit {path}: cannot write ({exc.strerror})") from None
