"""Query logic of the dashboard (thesis 4.6): aggregated run counts per folder, run lists, comparisons.

Counts are aggregated in the database grouped by test case and run outcome, then folded into folders
("contact_models/hertz/impact" lives in the folders ``contact_models`` and ``contact_models/hertz``).
The number of grouped rows is bounded by test cases x outcomes, never by the number of runs, and every
page costs a fixed number of queries.
"""
from __future__ import annotations

import math
import statistics
from dataclasses import dataclass, field
from types import SimpleNamespace

from django.apps import apps
from django.db import models
from django.db.models import (
    Case,
    Count,
    Exists,
    IntegerField,
    Max,
    Min,
    OuterRef,
    Prefetch,
    Q,
    Sum,
    Value,
    When,
)
from django.db.models.functions import Concat

from harness.store.rules import (
    CONSISTENT_LEVELS,
    OVERRIDE_SEPARATORS,
    SUCCESS_STATES,
    WHOLE_RUN,
    effective_state,
    gate_status,
    is_failing,
    relative_spread,
)


def _model(name: str):
    """A model of the store by name: harness.store.models imports this module for its QuerySets, so this module
    looks the models up in Django's app registry instead of importing them (no import circle)."""
    return apps.get_model("harness", name)

#: outcome categories of the two overview modes, in display order
STATE_CATEGORIES = ("successful", "failed", "not_executed", "outdated")
CONSISTENCY_CATEGORIES = ("consistent", "inconsistent", "no_reference", "not_checked")
#: what ``harness check`` says of a run (harness.analysis.check.gate_status): passed, failed, or not run (skipped)
VERDICT_CATEGORIES = ("passed", "failed", "not_run")


def verdict_category(state: str, consistency: str, accepted: bool) -> str:
    """The verdict category of a run from the columns an aggregation keeps (``accepted``: a reviewer
    overruled it, ``accepted_expression``), by the gate's one rule ``harness.store.rules.gate_status``."""
    status = gate_status(state, failure_accepted=accepted,
                         open_inconsistency=consistency == "inconsistent" and not accepted)
    return "not_run" if status == "skipped" else status


def state_category(state: str) -> str:
    """Overview category of a run state: successful, failed, not_executed or outdated."""
    if state in SUCCESS_STATES:
        return "successful"
    if state in ("failed", "not_executed", "outdated"):
        return state
    return "not_executed"


def consistency_category(consistency: str, accepted: bool) -> str:
    """Overview category in version consistency mode; an accepted (overruled) run counts as consistent."""
    if consistency in CONSISTENT_LEVELS:
        return "consistent"
    if consistency == "inconsistent":
        return "consistent" if accepted else "inconsistent"
    # checked, but the reference target has no run of this content to compare with: not "not checked"
    return "no_reference" if consistency == "no_reference" else "not_checked"


def accepted_expression():
    """SQL expression of ``harness.store.rules.is_accepted``: a failed run was overruled as a whole; an inconsistent
    run as a whole, or every bad quantity has its own override.

    A bad quantity is a ConsistencyResult whose level is neither perfect nor good (inconsistent, length
    mismatch, missing: ``harness.store.rules.quantity_fails``).
    """
    ConsistencyResult, Override = _model("ConsistencyResult"), _model("Override")
    whole_run = Exists(Override.objects.filter(run=OuterRef("pk"), quantity=WHOLE_RUN))
    # the keys `harness check` honours (harness.store.rules.override_keys): "ke", "torqueZ:torque", "torqueZ.torque"
    named = Q(quantity=OuterRef("quantity"))
    for separator in OVERRIDE_SEPARATORS:
        named |= Q(quantity=Concat(OuterRef("series_name"), Value(separator), OuterRef("quantity")))
    quantity_override = Override.objects.filter(run=OuterRef("run_id")).filter(named)
    unaccepted_bad = ConsistencyResult.objects.filter(run=OuterRef("pk")).exclude(
        level__in=CONSISTENT_LEVELS).exclude(Exists(quantity_override))
    overruled = Case(When(whole_run | ~Exists(unaccepted_bad), then=True), default=False,
                     output_field=models.BooleanField())
    whole = Case(When(whole_run, then=True), default=False, output_field=models.BooleanField())
    # only failed or inconsistent runs can be accepted: the subqueries run for those alone (CASE is lazy)
    return Case(When(state="failed", then=whole), When(consistency="inconsistent", then=overruled),
                default=False, output_field=models.BooleanField())


@dataclass
class Tally:
    """Aggregated outcome of the runs below one folder or test case.

    ``run_time`` is the summed engine wall time in s; ``lowest_c`` the lowest consistency C of any run.
    """

    name: str
    path: str
    is_testcase: bool = False
    has_subfolders: bool = False
    counts: dict = field(default_factory=dict)
    run_time: float = 0.0
    lowest_c: float | None = None
    accepted: int = 0
    #: runs per harness check verdict (VERDICT_CATEGORIES)
    verdicts: dict = field(default_factory=dict)
    #: when the latest of the runs started (None: none started)
    last_started: object = None

    @property
    def total(self) -> int:
        return sum(self.counts.get(c, 0) for c in STATE_CATEGORIES)

    def add(self, row: dict) -> None:
        n = row["n"]
        state_cat = state_category(row["state"])
        cons_cat = consistency_category(row["consistency"], row["accepted"])
        self.counts[state_cat] = self.counts.get(state_cat, 0) + n
        self.counts[cons_cat] = self.counts.get(cons_cat, 0) + n
        self.run_time += row["time"] or 0.0
        if row["accepted"]:
            self.accepted += n
        verdict = verdict_category(row["state"], row["consistency"], row["accepted"])
        self.verdicts[verdict] = self.verdicts.get(verdict, 0) + n
        if row.get("last") is not None and (self.last_started is None or row["last"] > self.last_started):
            self.last_started = row["last"]
        if row["cmin"] is not None and (self.lowest_c is None or row["cmin"] < self.lowest_c):
            self.lowest_c = row["cmin"]

    def share(self, mode: str = "state") -> float:
        """Fraction of successful (state mode) or consistent (consistency mode) runs, 0..1."""
        good = self.counts.get("consistent" if mode == "consistency" else "successful", 0)
        return good / self.total if self.total else 0.0

    def bar_color(self, mode: str = "state") -> str:
        """Thesis 4.6.1: red below 25 % success, blue up to 100 %, green at 100 %."""
        share = self.share(mode)
        if self.total and share >= 1.0:
            return "green"
        return "red" if share < 0.25 else "blue"

    @property
    def verdict(self) -> str:
        """The verdict of all these runs as ``harness check`` gives it: failed when any run failed, passed when
        any passed and none failed, not run when none ran."""
        if self.verdicts.get("failed"):
            return "failed"
        return "passed" if self.verdicts.get("passed") else "not_run"

    def matches(self, category: str | None) -> bool:
        """Whether this entry holds runs of the filtered category (no filter: always)."""
        return not category or self.counts.get(category, 0) > 0


def _child_name(testcase_path: str, prefix: str) -> str | None:
    """First path component of ``testcase_path`` below folder ``prefix`` ('' = root), or None."""
    if prefix:
        if not testcase_path.startswith(prefix + "/"):
            return None
        rest = testcase_path[len(prefix) + 1:]
    else:
        rest = testcase_path
    return rest.split("/", 1)[0]


def fold_into_children(rows, prefix: str) -> tuple[list[Tally], Tally]:
    """Fold rows grouped by test case path into the direct children of folder ``prefix``.

    Returns (children sorted by name, tally of the folder itself). A child is a test case when a test
    case has exactly its path, and has subfolders when a test case lies deeper below it.
    """
    children: dict[str, Tally] = {}
    whole = Tally(name=prefix.rsplit("/", 1)[-1] if prefix else "", path=prefix)
    for row in rows:
        path = row["testcase__path"]
        if path == prefix:
            whole.is_testcase = True
            whole.add(row)
            continue
        name = _child_name(path, prefix)
        if name is None:
            continue
        child_path = f"{prefix}/{name}" if prefix else name
        child = children.setdefault(name, Tally(name=name, path=child_path))
        if path == child_path:
            child.is_testcase = True
        else:
            child.has_subfolders = True
        child.add(row)
        whole.add(row)
    return [children[k] for k in sorted(children)], whole


def previous_builds(builds) -> dict:
    """For each of ``builds``: the build of its target on its machine just before it by commit date (then
    start), or None - the order of history (``RunQuerySet.history``). One query."""
    Build = _model("Build")
    builds = list(builds)
    order = ("committed_at", "started", "id")
    earlier: dict = {}
    for b in (Build.objects.filter(target_id__in={b.target_id for b in builds},
                                   machine_id__in={b.machine_id for b in builds})
              .exclude(committed_at=None).only("id", "target_id", "machine_id", "commit", "committed_at", "started")):
        earlier.setdefault((b.target_id, b.machine_id), []).append(b)

    def key(b):
        return tuple((getattr(b, f) is None, getattr(b, f)) for f in order)

    out = {}
    for build in builds:
        if build.committed_at is None:
            out[build.pk] = None
            continue
        before = [b for b in earlier.get((build.target_id, build.machine_id), []) if key(b) < key(build)]
        out[build.pk] = max(before, key=key) if before else None
    return out


def stepping_changes(builds) -> dict:
    """Stepping time of each of ``builds`` against the build before it (``previous_builds``).

    The runs of both builds are paired by test case and run name (the shortest stepping time of each, in s);
    the change is the geometric mean of the ratios now / before over the pairs, so that a 5 ms test counts
    as much as a 5 s one; ``noise`` is the median over the pairs of the larger measured spread of repeated
    stepping times (harness.store.rules.relative_spread, ``harness run --repeat``; 0 without repeats).
    Returns ``{build id: {"ratio", "pairs", "previous" (Build), "noise"}}`` for the builds with at least one
    pair. Two queries.
    """
    Run = _model("Run")
    previous = {pk: b for pk, b in previous_builds(builds).items() if b is not None}
    if not previous:
        return {}
    times: dict = {}
    for build_id, testcase_id, name, stepping, timing in (
            Run.objects.filter(build_id__in=set(previous) | {b.pk for b in previous.values()}, replaced=False,
                               stepping_time__gt=0)
            .order_by("stepping_time").values_list("build_id", "testcase_id", "name", "stepping_time", "timing")):
        # the shortest stepping time of each run configuration, with the spread of its repeats
        times.setdefault(build_id, {}).setdefault((testcase_id, name), (stepping, relative_spread(timing)))
    out = {}
    for pk, before in previous.items():
        now, then = times.get(pk, {}), times.get(before.pk, {})
        shared = now.keys() & then.keys()
        if shared:
            logs = [math.log(now[k][0] / then[k][0]) for k in shared]
            noise = statistics.median(max(now[k][1], then[k][1]) for k in shared)
            out[pk] = {"ratio": math.exp(sum(logs) / len(logs)), "pairs": len(logs), "previous": before,
                       "noise": noise}
    return out


class BuildQuerySet(models.QuerySet):
    """Builds, for the overview's failures and the build page."""

    def unresolved_failures(self):
        """Failed builds (not interrupted) newer than their target's current build on that machine, or of a
        target with no current build there: what the overview shows as a target that does not build."""
        current = self.model.objects.filter(target_id=OuterRef("target_id"), machine_id=OuterRef("machine_id"),
                                            current=True, finished__gte=OuterRef("finished"))
        not_interrupted = Q(details__interrupted__isnull=True) | Q(details__interrupted=False)
        return (self.filter(not_interrupted, status="failed").exclude(Exists(current))
                .select_related("target", "machine").order_by("machine__name", "target__name", "-finished"))


class RunQuerySet(models.QuerySet):
    """Runs, with the aggregations the dashboard lists need."""

    def with_accepted(self):
        """The runs, each with ``accepted``: a reviewer overruled it (``accepted_expression``)."""
        return self.annotate(accepted=accepted_expression())

    def accepted(self):
        """The runs a reviewer overruled (``harness.store.rules.is_accepted``)."""
        return self.with_accepted().filter(accepted=True)

    def failing(self):
        """The failing runs (``harness.store.rules.is_failing``): failed for their own build or inconsistent, and not
        accepted by a reviewer. ``harness list -q`` lists them."""
        failed = Q(state="failed") | (Q(state="outdated", replaced=False) & ~Q(failure_reason=""))
        return self.with_accepted().filter(failed | Q(consistency="inconsistent"), accepted=False)

    def current(self, build=None):
        """The runs a verdict covers: the live rows (not replaced by a newer run of other content) of each
        target's current build, or of ``build``. ``harness.analysis.coverage`` keeps these rows exactly the selected
        run configurations; ``harness check``, ``ci``, ``list``, both JUnit writers and the dashboard's
        overview and lists read them."""
        runs = self.filter(replaced=False)
        return runs.filter(build=build) if build is not None else runs.filter(build__current=True)

    def below(self, folder: str):
        """Runs of test cases in ``folder`` or below it, or of the test case with that path."""
        if not folder:
            return self
        return self.filter(Q(testcase__path=folder) | Q(testcase__path__startswith=folder + "/"))

    def outcome_rows(self, *group_by: str):
        """Rows grouped by ``group_by`` + test case path + state + consistency + accepted.

        Each row has ``n`` runs, summed wall ``time`` in s and the lowest consistency ``cmin``.
        """
        return (self.with_accepted()
                .values(*group_by, "testcase__path", "state", "consistency", "accepted")
                .annotate(n=Count("id"), time=Sum("wall_time"), cmin=Min("consistency_min"), last=Max("started"))
                .order_by())

    def overview(self) -> list[dict]:
        """Machines, their targets, and each target's top-level folders with tallies (one query).

        Returns ``[{"machine": name, "machine_id": id, "targets": [{"target": name, "target_id": id,
        "reference": name or None, "tally": Tally, "folders": [Tally]}]}]``.
        """
        rows = self.outcome_rows("machine_id", "machine__name", "target_id", "target__name",
                                 "target__reference__name")
        grouped: dict = {}
        for row in rows:
            key_m = (row["machine__name"], row["machine_id"])
            key_t = (row["target__name"], row["target_id"], row["target__reference__name"])
            grouped.setdefault(key_m, {}).setdefault(key_t, []).append(row)
        result = []
        for (m_name, m_id) in sorted(grouped):
            targets = []
            for (t_name, t_id, ref) in sorted(grouped[(m_name, m_id)], key=lambda k: k[0]):
                folders, whole = fold_into_children(grouped[(m_name, m_id)][(t_name, t_id, ref)], "")
                targets.append({"target": t_name, "target_id": t_id, "reference": ref,
                                "tally": whole, "folders": folders})
            result.append({"machine": m_name, "machine_id": m_id, "targets": targets})
        return result

    def folder(self, folder: str) -> tuple[list[Tally], Tally]:
        """Children of ``folder`` with tallies, and the folder's own tally (one query)."""
        return fold_into_children(self.below(folder).outcome_rows(), folder)

    def in_category(self, category: str | None):
        """Filter by an overview category (successful, failed, ..., consistent, inconsistent, no_reference,
        not_checked)."""
        if not category:
            return self
        if category == "successful":
            return self.filter(state__in=SUCCESS_STATES)
        if category in ("failed", "not_executed", "outdated"):
            return self.filter(state=category)
        qs = self.with_accepted()
        if category == "consistent":
            return qs.filter(Q(consistency__in=CONSISTENT_LEVELS) | Q(consistency="inconsistent", accepted=True))
        if category == "inconsistent":
            return qs.filter(consistency="inconsistent", accepted=False)
        if category == "no_reference":
            return qs.filter(consistency="no_reference")
        if category == "not_checked":
            return qs.exclude(consistency__in=CONSISTENT_LEVELS + ("inconsistent", "no_reference"))
        return self.none()

    def search(self, q=None, commit=None, build=None, state=None, reason=None):
        """The dashboard's search and filters, each skipped when None: ``q`` a substring (any case) of the test
        case path or the run name, ``commit`` the start of the build's commit id, ``build`` a build id,
        ``state`` a run state, ``reason`` a failure reason."""
        qs = self
        if q:
            qs = qs.filter(Q(testcase__path__icontains=q) | Q(name__icontains=q))
        if commit:
            qs = qs.filter(build__commit__startswith=commit.lower())
        if build is not None:
            qs = qs.filter(build_id=build)
        if state:
            qs = qs.filter(state=state)
        if reason:
            qs = qs.filter(failure_reason=reason)
        return qs

    def listing(self):
        """Runs for a table: with build, target, machine, test case and the accepted flag (one query)."""
        return (self.select_related("build", "target", "machine", "testcase")
                .with_accepted()
                .order_by("testcase__path", "name", "-build__committed_at", "-id"))

    def detail(self):
        """One run with everything its page shows, in a fixed number of queries."""
        ConsistencyResult, Override = _model("ConsistencyResult"), _model("Override")
        return (self.select_related("build", "target", "target__reference", "machine", "testcase",
                                    "reference_run", "reference_run__build", "reference_run__target")
                .with_accepted()
                .prefetch_related("series",
                                  Prefetch("consistency_results",
                                           queryset=ConsistencyResult.objects.order_by(
                                               "value", "series_kind", "series_name", "quantity")),
                                  Prefetch("overrides",
                                           queryset=Override.objects.select_related("user").order_by("created"))))

    def history(self, target, testcase, machine=None):
        """Runs of one test case by the successive builds of a target, oldest build first."""
        qs = self.filter(target=target, testcase=testcase)
        if machine is not None:
            qs = qs.filter(machine=machine)
        return (qs.select_related("build", "machine").with_accepted()
                .order_by("build__committed_at", "build__started", "build_id", "name"))

    def reference_candidates(self, run, reference_target: str):
        """Successful runs of ``reference_target`` that may serve as ``run``'s reference, best first (thesis
        4.4): same test case, run name and test case content; the reference target's current build on this
        machine first, then its newest runs on this machine, then on any machine (imported results)."""
        return (self.filter(target__name=reference_target, testcase_id=run.testcase_id, name=run.name,
                            testcase_hash=run.testcase_hash, state__in=SUCCESS_STATES)
                .annotate(preference=Case(
                    When(machine_id=run.machine_id, build__current=True, then=Value(0)),
                    When(machine_id=run.machine_id, then=Value(1)), default=Value(2),
                    output_field=IntegerField()))
                .order_by("preference", "-finished", "-id"))

    def find_reference(self, run, reference_target: str | None):
        """The reference run of ``run`` by ``reference_target`` (None: no target, or no run of this content)."""
        if not reference_target:
            return None
        return self.reference_candidates(run, reference_target).first()

    def stale_reference(self, run, reference_target: str):
        """A successful reference run of the same test case and run name but other content (or None).

        Used to say why there is no reference run: the reference ran an earlier (or later) version of the
        test case, and ``harness run`` of the reference target refreshes it.
        """
        return (self.filter(target__name=reference_target, testcase_id=run.testcase_id, name=run.name,
                            state__in=SUCCESS_STATES).exclude(testcase_hash=run.testcase_hash)
                .select_related("build").order_by("-finished", "-id").first())

    def reference_for(self, run):
        """The reference run of ``run``: the one its check scored against, else the one ``harness check``
        would choose (``find_reference``); None without a reference target."""
        if run.reference_run_id:
            return self.detail().filter(pk=run.reference_run_id).first()
        if not run.target.reference_id:
            return None
        found = self.find_reference(run, run.target.reference.name)
        return self.detail().filter(pk=found.pk).first() if found is not None else None

    def matrix_runs(self, target_names, machine_name: str) -> dict:
        """Ids of the runs harness.analysis.matrix scores: the successful, not replaced runs of each target's current
        build on the machine, as ``{(target, test case path, run name, content hash): run id}`` (one query,
        no series)."""
        rows = (self.filter(target__name__in=list(target_names), machine__name=machine_name, build__current=True,
                            build__status="complete", replaced=False, state__in=SUCCESS_STATES)
                .order_by("id").values_list("target__name", "testcase__path", "name", "testcase_hash", "id"))
        return {(t, path, name, content): pk for t, path, name, content, pk in rows}

    def failing_since(self, runs) -> dict:
        """For each failed or inconsistent run of ``runs``: since which build of its target on its machine
        the run configuration (test case and run name) has failed or been inconsistent without interruption.

        The history is that of ``history``: the builds of the target on the machine that ran the run
        configuration, by commit date; per build its run (the one no newer content replaced, else the newest).
        A run counts as bad when it is failing (``harness.store.rules.is_failing``: failed for its own build or
        inconsistent, not overruled by a reviewer); a successful, consistent (or overruled) run interrupts; a run not executed is
        no evidence either way and is passed over. Returns ``{run id: {"commit", "committed_at", "build_id",
        "run_id", "builds" (bad builds in the streak), "first" (the streak starts at the first recorded
        build)}}``; one query for any number of runs, none when no run is bad.
        """
        def bad(r) -> bool | None:
            if is_failing(r):
                return True
            return None if not r.accepted and effective_state(r) in ("not_executed", "outdated") else False

        wanted = [r for r in runs if bad(r)]
        if not wanted:
            return {}
        keys = {(r.target_id, r.machine_id, r.testcase_id, r.name) for r in wanted}
        fields = ("pk", "target_id", "machine_id", "testcase_id", "name", "build_id", "build__commit",
                  "build__committed_at", "state", "replaced", "failure_reason", "finished", "consistency",
                  "accepted")
        rows = (self.filter(target_id__in={k[0] for k in keys}, machine_id__in={k[1] for k in keys},
                            testcase_id__in={k[2] for k in keys}, name__in={k[3] for k in keys})
                .with_accepted().order_by("build__committed_at", "build__started", "build_id", "replaced", "-id")
                .values_list(*fields))
        histories: dict = {}
        for row in rows:
            r = SimpleNamespace(**dict(zip(fields, row)))
            builds = histories.setdefault((r.target_id, r.machine_id, r.testcase_id, r.name), {})
            builds.setdefault(r.build_id, r)  # the build's first row: not replaced, newest
        out = {}
        for run in wanted:
            history = list(histories.get((run.target_id, run.machine_id, run.testcase_id, run.name), {}).values())
            position = next((i for i, r in enumerate(history) if r.build_id == run.build_id), None)
            if position is None:
                continue
            start, count, i = position, 1, position - 1
            while i >= 0:
                verdict = bad(history[i])
                if verdict is False:
                    break
                if verdict:
                    start, count = i, count + 1
                i -= 1
            first = history[start]
            out[run.pk] = {"commit": first.build__commit, "committed_at": first.build__committed_at,
                           "build_id": first.build_id, "run_id": first.pk, "builds": count,
                           "first": all(bad(r) is None for r in history[:start])}
        return out
