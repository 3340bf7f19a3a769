"""JUnit XML of the runs in the store, as CI reads it: one test suite per machine and target.

A failed run is a failure, an inconsistent run a failure too, unless a reviewer overruled it (the reason
is then kept in the output); a run not executed is skipped.
"""
from __future__ import annotations

from junit_xml import TestCase as JUnitCase, TestSuite, to_xml_report_string

from webfrontend.presentation import revision_label


def junit_xml(runs) -> str:
    """XML text for ``runs`` (from ``Run.objects.junit()``, with the ``accepted`` annotation)."""
    suites: dict[tuple[str, str], list[JUnitCase]] = {}
    for run in runs:
        case = JUnitCase(name=run.name, classname=run.testcase.path.replace("/", "."),
                         elapsed_sec=run.wall_time or 0.0,
                         stdout=f"build {revision_label(run.build)}, state {run.get_state_display()}")
        if run.state == "not_executed":
            case.add_skipped_info("not executed")
        elif run.state == "failed" and not run.accepted:
            case.add_failure_info(f"failed: {run.get_failure_reason_display()}", run.failure_message)
        elif run.consistency == "inconsistent" and not run.accepted:
            case.add_failure_info(f"inconsistent with the reference: lowest C = {run.consistency_min}")
        elif run.accepted:
            case.stderr = "overruled by a reviewer (see the dashboard for who, when and why)"
        suites.setdefault((run.machine.name, run.target.name), []).append(case)
    return to_xml_report_string([TestSuite(f"{target} on {machine}", cases)
                                 for (machine, target), cases in suites.items()])
