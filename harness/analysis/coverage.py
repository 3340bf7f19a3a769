"""What a verdict covers: every selected run configuration of a target's build, recorded in the store.

``record_selection`` makes the store hold exactly one live row (``replaced`` false) per run configuration a
target selects now (its test cases at the content of now, filtered by ``-k``), so that every reader of the
store - ``harness check``, ``harness ci``, the JUnit XML of the CLI and of the dashboard, the overview -
sees the same set of runs and gives them the same verdicts (``harness.analysis.check.verdict_of``):

- a broken configuration (invalid run.config, a broken entry) is a row failed with reason ``config``;
- a run configuration without a row (never run, or run at other test case content) gets a row
  ``not_executed``: a failure of the gate unless ``--allow-missing``;
- a row whose run configuration is gone from the test cases is marked outdated and replaced: it says
  nothing about the test cases of now.

``harness run`` calls it when it plans (so a run killed before it was submitted is still in the store as
not executed), ``harness check`` and ``harness ci`` before they give verdicts. A row is only ever inserted
when missing, never overwritten with "not executed", so a process that stores a finished run at the same
moment loses nothing.

A target whose revision does not build has that failed build as its current build
(``harness.execution.builds.failed_build``): its selected run configurations are rows failed with reason
``build_failed`` (``missing`` below; never executed, so no start time), and ``failed_current_builds`` adds
the build itself to the JUnit XML as the failing test case ``build``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from harness.adapters import get_adapter
from harness.adapters.base import UserError
from harness.config.testcases import CONFIG_RUN, discover, matches
from harness.execution import execute as ex
from harness.execution.builds import BUILD_FAILED
from harness.execution.planning import build_info, make_spec
from harness.store.records import store_record


@dataclass
class Selection:
    """The run configurations a target selects now: ``{(test case path, run name): content hash}``, and
    the discovery problems (files that could not be read)."""

    content: dict[tuple[str, str], str] = field(default_factory=dict)
    broken: dict[tuple[str, str], str] = field(default_factory=dict)   # key -> the config problem
    problems: list[str] = field(default_factory=list)


def selected(pattern: str | None, path: str, name: str) -> bool:
    """Whether ``-k pattern`` selects run ``name`` of test case ``path``; a broken run.config (the pseudo run
    ``run.config``) is selected by its test case path, as ``harness run`` plans it."""
    return matches(pattern, path, name) or (name == CONFIG_RUN and matches(pattern, path, ""))


def selection(target, pattern: str | None = None, working_tree: bool = False, discovered=None):
    """The run configurations ``target`` selects now (None: its test cases cannot be read); ``discovered``:
    the (test cases, problems) of ``harness.config.testcases.discover`` when the caller has them already."""
    if discovered is None:
        try:
            discovered = discover(target, get_adapter(target.engine), working_tree)
        except UserError:
            return None, []
    testcases, problems = discovered
    chosen = Selection(problems=list(problems))
    specs = []
    for testcase in testcases:
        for entry in testcase.runs:
            if not selected(pattern, testcase.path, entry.name):
                continue
            key = (testcase.path, entry.name)
            chosen.content[key] = testcase.content_hash(entry.name)
            if entry.problems:
                chosen.broken[key] = "; ".join(entry.problems)
            specs.append((testcase, entry))
    return chosen, specs


def record_selection(target, build, machine: str, pattern: str | None = None, working_tree: bool = False,
                     missing: tuple[str, str] | None = None, discovered=None):
    """Bring the store's live rows of ``build`` on ``machine`` in line with the run configurations ``target``
    selects now (see the module docstring). Returns the Selection (None when the test cases cannot be read:
    then nothing is changed).

    ``missing``: (failure reason, message) to record the run configurations without a row as failed with,
    instead of not executed - e.g. the runs of a build that failed, which can never execute."""
    # the store's models load once Django is set up (harness.store)
    from harness.store.models import Run

    chosen, specs = selection(target, pattern, working_tree, discovered)
    if chosen is None:
        return None
    adapter = get_adapter(target.engine)
    info = build_info(build)
    live = {(r.testcase.path, r.name, r.testcase_hash): r for r in
            Run.objects.filter(machine__name=machine, build=build, replaced=False).select_related("testcase")}
    for testcase, entry in specs:
        key = (testcase.path, entry.name)
        row = live.get((*key, chosen.content[key]))
        problem = chosen.broken.get(key)
        if problem is not None:
            if row is None or row.state != "failed" or row.failure_reason != "config" \
                    or row.failure_message != problem:
                record = ex.fail(ex.base_record(make_spec(target, info, adapter, machine, testcase, entry)),
                                 "config", problem)
                record.finished = ex.now_iso()
                store_record(record)
            continue
        if row is None or (missing is not None and row.state == "not_executed"):
            record = ex.base_record(make_spec(target, info, adapter, machine, testcase, entry))
            if missing is not None:
                record = ex.fail(record, *missing)
                record.finished = ex.now_iso()
            store_record(record, only_new=missing is None)
    # rows of run configurations the test cases no longer hold (within the selection's pattern)
    for (path, name, _content), row in live.items():
        if (path, name) not in chosen.content and selected(pattern, path, name):
            Run.objects.filter(pk=row.pk).update(state=Run.State.OUTDATED, replaced=True)
    return chosen


def record_build_failure(target, build, machine_name: str, pattern: str | None = None, working_tree: bool = False):
    """Record every selected run configuration of ``target`` that has no row at the failed ``build`` as
    failed with reason ``BUILD_FAILED`` and the build's first error line: the runs were never executed (no
    start time, no run folder) and fail the gate, whatever ``--allow-missing``."""
    return record_selection(target, build, machine_name, pattern, working_tree,
                            missing=(BUILD_FAILED, (build.details or {}).get("error") or "build failed"))


def covered_runs(machine_id: int | None = None, target_id: int | None = None, build=None, machine: str | None = None):
    """The runs a verdict covers (``RunQuerySet.current``), in report order: the live rows (not replaced by
    other content) of each target's current build - or of ``build`` - on each machine (optionally one machine
    and target). After ``record_selection`` these are exactly the selected run configurations. ``harness check``, ``ci``, both
    JUnit writers and the dashboard's overview and pages read this set."""
    # the store's models (Django) load once Django is set up (harness.store)
    from django.db.models import Prefetch

    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import ConsistencyResult, Override, Run

    runs = Run.objects.current(build)
    if machine is not None:
        runs = runs.filter(machine__name=machine)
    if machine_id is not None:
        runs = runs.filter(machine_id=machine_id)
    if target_id is not None:
        runs = runs.filter(target_id=target_id)
    return (runs.select_related("machine", "target", "build", "testcase", "reference_run__target",
                                "reference_run__build")
            .prefetch_related(Prefetch("consistency_results", queryset=ConsistencyResult.objects.order_by("pk")),
                              Prefetch("overrides", queryset=Override.objects.select_related("user")))
            .order_by("machine__name", "target__name", "testcase__path", "name"))


def earlier_content_run(run):
    """The newest finished run of the same build, test case and run name at other (earlier) test case
    content, when ``run`` is a not-executed row that took its place (None otherwise): the run is stale."""
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Run

    if run.state != "not_executed":
        return None
    return (Run.objects.filter(machine_id=run.machine_id, build_id=run.build_id, testcase_id=run.testcase_id,
                               name=run.name, replaced=True).exclude(testcase_hash=run.testcase_hash)
            .exclude(finished=None).order_by("-finished", "-id").first())


def failed_current_builds(machine_id: int | None = None, target_id: int | None = None):
    """The current builds that failed (optionally of one machine and target): the targets whose revision does
    not build. Both JUnit writers add one failing test case ``build`` for each (``harness.report.junit``)."""
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Build

    builds = Build.objects.filter(current=True, status=Build.Status.FAILED).select_related("target", "machine")
    if machine_id is not None:
        builds = builds.filter(machine_id=machine_id)
    if target_id is not None:
        builds = builds.filter(target_id=target_id)
    return list(builds.order_by("target__name", "machine__name", "pk"))
