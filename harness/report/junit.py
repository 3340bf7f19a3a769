"""JUnit XML for CI - the one writer the CLI (``harness check --junit``) and the dashboard share.

The layout is the one Jenkins' xunit plugin validates (its ``junit-10.xsd``) and Jenkins' junit step reads:
``<testsuites>`` of ``<testsuite>`` per target and test case folder, each with ``<properties>`` naming the
target, its commit and the reference target's commits, and a ``<testcase>`` per run whose ``classname`` is
``TARGET.folder.subfolder`` (runs of two targets never collide). Times are seconds with at most three
decimals (the schema's SUREFIRE_TIME); a testcase carries only ``name``, ``classname`` and ``time``.
A failed run or an inconsistency not accepted by a reviewer is a ``<failure>``; a run not executed is
``<skipped>`` (a failure unless ``--allow-missing``); a target whose current build failed has a suite
``TARGET/build`` with the one failing test case ``build``; ``<system-out>`` says what the verdict was
computed on, then the log tail. Texts use the words of ``harness.report.glossary`` (consistency levels,
"overruled", "not run"), as the CLI and the dashboard do.
"""
from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path

from harness.report.glossary import level_word

#: characters XML 1.0 cannot hold (engine logs sometimes carry them)
_NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ufffe\uffff]")


def _text(value: str) -> str:
    return _NOT_XML.sub("\ufffd", value or "")


def _seconds(value) -> str:
    return f"{max(0.0, float(value or 0.0)):.3f}"


def _log_tail(run) -> str:
    record = Path(run.folder or "/nonexistent") / "run.json"
    try:
        return json.loads(record.read_text(encoding="utf-8")).get("log_tail", "")
    except (OSError, ValueError):
        return ""


def provenance(run) -> str:
    """What a verdict was computed on: target and commit, test case content, reference and its commit."""
    text = f"{run.target.name} at {run.build.commit[:10]}, test case {run.short_hash or '-'}"
    reference = run.reference_run
    if reference is not None:
        text += f"; reference {reference.target.name} at {reference.build.commit[:10]}"
    return text


def _case(verdict) -> ET.Element:
    run = verdict.run
    case = ET.Element("testcase", name=_text(run.name),
                      classname=_text(f"{run.target.name}.{run.testcase.path.replace('/', '.')}"),
                      time=_seconds(run.wall_time))
    notes = [provenance(run)]
    if verdict.results:
        lowest = min((r.value for r in verdict.results if r.value is not None), default=None)
        notes.append(f"consistency level {level_word(run.consistency)}"
                     + (f", lowest C = {lowest:.4g}" if lowest is not None else ""))
    notes += verdict.overridden  # "reviewer: reason - overruled what" (harness.analysis.check.overruled)
    if verdict.message and verdict.status != "failed":
        notes.append(verdict.message)
    if verdict.status == "failed":
        failure = ET.SubElement(case, "failure", type=_text(verdict.kind or "failure"),
                                message=_text(verdict.message[:2000]))
        failure.text = _text(verdict.message)
    elif verdict.status == "skipped":
        ET.SubElement(case, "skipped", message=_text(verdict.message))
    tail = _log_tail(run)
    ET.SubElement(case, "system-out").text = _text("\n".join(notes) + ("\n--- log tail ---\n" + tail if tail else ""))
    return case


def junit_xml(verdicts, failed_builds=()) -> str:
    """The XML text for ``verdicts`` (``harness.analysis.check.RunVerdict``: run, status, message, kind, ...), then a
    ``build_failure_suite`` per failed build of ``failed_builds`` (the targets' current builds that failed),
    ordered by target and machine so that every caller writes the same bytes."""
    suites: dict[tuple[str, str], list] = {}
    for verdict in verdicts:
        suites.setdefault((verdict.run.target.name, verdict.run.testcase.path), []).append(verdict)
    root = ET.Element("testsuites", name="harness")
    totals = {"tests": 0, "failures": 0, "time": 0.0}
    for (target, path), members in suites.items():
        failures = sum(v.status == "failed" for v in members)
        skipped = sum(v.status == "skipped" for v in members)
        time = sum(float(v.run.wall_time or 0.0) for v in members)
        suite = ET.SubElement(root, "testsuite", name=_text(f"{target}/{path}"), tests=str(len(members)),
                              failures=str(failures), errors="0", skipped=str(skipped), time=_seconds(time))
        properties = ET.SubElement(suite, "properties")
        references = sorted({(v.run.reference_run.target.name, v.run.reference_run.build.commit)
                             for v in members if v.run.reference_run is not None})
        for name, value in [("target", target),
                            ("target_commit", " ".join(sorted({v.run.build.commit for v in members}))),
                            ("reference", " ".join(sorted({n for n, _ in references}))),
                            ("reference_commit", " ".join(c for _, c in references))]:
            if value:
                ET.SubElement(properties, "property", name=name, value=_text(value))
        for verdict in members:
            suite.append(_case(verdict))
        totals["tests"] += len(members)
        totals["failures"] += failures
        totals["time"] += time
    for build in sorted(failed_builds, key=lambda b: (b.target.name, b.machine.name, b.pk)):
        suite = build_failure_suite(build)
        root.append(suite)
        totals["tests"] += 1
        totals["failures"] += 1
        totals["time"] += float(build.duration or 0.0)
    root.set("tests", str(totals["tests"]))
    root.set("failures", str(totals["failures"]))
    root.set("errors", "0")
    root.set("time", _seconds(totals["time"]))
    ET.indent(root)
    return '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def build_failure_suite(build) -> ET.Element:
    """A ``<testsuite>`` ``TARGET/build`` with the one failing test case ``build`` of a failed build
    (``harness.execution.builds``): the target's runs cannot execute, so CI sees the build as the failure, with the
    first error line as the message and the log tail as output. Append it to ``junit_xml``'s root for
    every target whose current build failed."""
    details = build.details or {}
    message = details.get("error") or "build failed"
    suite = ET.Element("testsuite", name=_text(f"{build.target.name}/build"), tests="1", failures="1",
                       errors="0", skipped="0", time=_seconds(build.duration))
    properties = ET.SubElement(suite, "properties")
    for name, value in (("target", build.target.name), ("target_commit", build.commit)):
        ET.SubElement(properties, "property", name=name, value=_text(value))
    case = ET.SubElement(suite, "testcase", name="build", classname=_text(f"{build.target.name}.build"),
                         time=_seconds(build.duration))
    failure = ET.SubElement(case, "failure", type="build_failed", message=_text(message[:2000]))
    failure.text = _text(message)
    tail = "\n".join((build.log or "").strip().splitlines()[-40:])
    ET.SubElement(case, "system-out").text = _text(f"{build.target.name} at {build.commit[:10]}: build failed "
                                                   f"after {_seconds(build.duration)} s\n--- log tail ---\n{tail}")
    return suite
