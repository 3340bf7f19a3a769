"""Verdicts from what the store holds: the RunVerdict ``harness check`` gives, built from a run's stored
ConsistencyResult rows instead of a fresh comparison, so that the dashboard (run page, /junit.xml) and the
CLI cannot disagree - the rules (which states fail, how an override is honoured, how JUnit is written) stay
in harness.analysis.check and harness.store.rules.

The set of runs is ``harness.analysis.coverage.covered_runs``: after a ``harness check`` (or ``run``) it holds every
selected run configuration, broken ones and runs not executed included, and a test case changed on disk is a
not-executed run of the new content (stale), so the dashboard's JUnit is the CLI's to the byte. What the
store cannot tell: a test case changed on disk since the last ``harness check`` or ``run``. A post-processed run the check has not scored yet says so in its
message (``harness check`` scores every such run before it writes its report, so its reports never have one).
"""
from __future__ import annotations

from harness.analysis.check import CheckReport, RunVerdict, junit_xml, verdict_of

#: a checkable run the check has not scored yet (its consistency is still blank)
NOT_CHECKED = "not checked against the reference yet (run 'harness check')"


def stored_results(run) -> list:
    """The run's ConsistencyResult rows in the order ``harness check`` stored them (prefetched rows are used
    as they are)."""
    return sorted(run.consistency_results.all(), key=lambda r: r.pk)


def has_reference_target(run) -> bool:
    return run.target.reference_id is not None


def stored_verdict(run, allow_missing: bool = False) -> RunVerdict:
    """What ``harness check`` said (or would say) of ``run``, from the stored results and overrides."""
    verdict = verdict_of(run, stored_results(run), has_reference_target(run), allow_missing)
    if (verdict.status == "passed" and not verdict.message and has_reference_target(run)
            and run.state == "post_processed" and not run.consistency):
        verdict.message = NOT_CHECKED
    return verdict


def stored_report(runs, allow_missing: bool = False) -> CheckReport:
    return CheckReport(verdicts=[stored_verdict(run, allow_missing) for run in runs])


def stored_junit_xml(runs, allow_missing: bool = False, failed_builds=()) -> str:
    """JUnit XML of ``runs`` (e.g. ``harness.analysis.coverage.covered_runs(machine, target)``) and of ``failed_builds`` (e.g.
    ``harness.analysis.coverage.failed_current_builds(machine, target)``) by harness.analysis.check's writer;
    ``allow_missing`` as ``harness check --allow-missing``."""
    report = stored_report(runs, allow_missing)
    report.failed_builds = list(failed_builds)
    return junit_xml(report)
