"""Views of the dashboard (thesis 4.6): each a query (harness/store/queries.py) and a render.

Anonymous users read everything; only a logged-in user may overrule (POST with CSRF token). Every query
string value is read through webfrontend.params (a bad one is a 400 naming it), every path value through
the URL converters there (a bad one is a 404). Counts and verdicts are those of each target's current build
(``build__current=True``, not replaced); runs of older builds stay reachable from history and run pages.
"""
from __future__ import annotations

from django.conf import settings
from django.contrib import messages
from django.contrib.auth.decorators import login_required
from django.core.paginator import Paginator
from django.db.models import Count, Q
from django.http import FileResponse, Http404, HttpResponse, JsonResponse
from django.shortcuts import get_object_or_404, redirect, render
from django.urls import reverse
from django.utils.http import urlencode
from django.views.decorators.http import require_POST

from harness.analysis.compare import HEADER, compare_builds, summary
from harness.analysis.coverage import covered_runs, failed_current_builds
from harness.analysis.matrix import Matrix, _c, build_matrix, to_json
from harness.analysis.regressions import comparable, histories
from harness.analysis.verdicts import stored_junit_xml, stored_verdict
from harness.config.sweep import current_sweeps, find_sweep
from harness.execution.builds import current_build
from harness.store.models import (
    Build,
    ConsistencyResult,
    Machine,
    Override,
    Run,
    Series,
    Target,
    TestCase,
)
from harness.store.queries import (
    CONSISTENCY_CATEGORIES,
    STATE_CATEGORIES,
    fold_into_children,
    previous_builds,
    stepping_changes,
)
from harness.store.runrecord import FAILURE_REASONS
from webfrontend import efficiency, params, plots, presentation
from webfrontend.forms import OverrideForm
from webfrontend.runfiles import RunFolder

#: runs one comparison shows at most: each adds a timing bar and a curve to every plot, and beyond a few
#: dozen the page says nothing more (the page says so; more is a 400 naming the limit)
COMPARE_LIMIT = settings.DASHBOARD_COMPARE_LIMIT
#: builds the build comparison form offers at most
BUILD_CHOICE_LIMIT = 500
#: rows of a run list per page
LIST_PAGE_SIZE = settings.DASHBOARD_LIST_PAGE_SIZE
MODES = ("state", "consistency")
#: fields of a run (and its build) no run list shows: left in the database, whatever their size
LIST_DEFERRED = ("config", "command", "timing", "breakdown", "failure_message", "folder", "build__log",
                 "build__commit_message", "build__environment", "build__executable")


def _mode(request) -> tuple[str, str | None]:
    """(mode, category filter) from the query string."""
    mode = params.choice(request.GET, "mode", MODES, "state")
    show = params.choice(request.GET, "show", CONSISTENCY_CATEGORIES if mode == "consistency" else STATE_CATEGORIES)
    return mode, show


def _filters(request) -> dict:
    """The run lists' search and filters (webfrontend.params.run_filters) and what their pages need: the
    values, the query string that keeps them in every link (``filter_query``), the choices of the form."""
    values = params.run_filters(request.GET)
    kept = {k: v for k, v in values.items() if v is not None}
    return {"filters": values, "filtered": bool(kept), "filter_query": urlencode(kept),
            "run_states": Run.State.choices,
            "failure_reasons": [(r, Run.FailureReason(r).label) for r in FAILURE_REASONS if r]}


def _run_list(queryset):
    """A run list's queryset: the reference run's build for provenance, big fields left out."""
    return queryset.select_related("reference_run__build", "reference_run__target").defer(*LIST_DEFERRED)


def _page(request, queryset):
    return Paginator(queryset, LIST_PAGE_SIZE).get_page(params.page_number(request.GET))


def _with_failing_since(page):
    """The page's runs, each failed or inconsistent one with ``failing_since`` (RunQuerySet.failing_since:
    the first build of the uninterrupted streak); one query for the page."""
    page.object_list = list(page.object_list)
    since = Run.objects.failing_since(page.object_list)
    for run in page.object_list:
        run.failing_since = since.get(run.pk)
    return page


def _plots_json(plot_list: list[dict]) -> JsonResponse:
    """Plots for plots.js (webfrontend.plots says what one holds); no NaN in the JSON (finite_or_none)."""
    response = JsonResponse({"plots": plot_list}, json_dumps_params={"allow_nan": False, "separators": (",", ":")})
    response["Cache-Control"] = "max-age=60"
    return response


def bad_request(request, exception):
    """400 page: the problem when the dashboard named it (webfrontend.params), else nothing of the request."""
    named = isinstance(exception, params.BadParameter)
    return render(request, "400.html", {"problem": str(exception) if named else "",
                                        "links": exception.links if named else []}, status=400)


def overview(request):
    """One compact table per machine: a row per target (its current build), failing targets first, with the
    verdict ``harness check`` gives, the commit, run counts, consistency, the stepping-time change against
    the build before and when it last ran. With a search or filter, the matching runs are listed below."""
    mode, _ = _mode(request)
    selected = params.optional_id(request.GET, "machine")
    found = _filters(request)
    runs = Run.objects.search(**found["filters"]).current()
    everything = Run.objects.search(**found["filters"])
    if selected is not None:
        runs, everything = runs.filter(machine_id=selected), everything.filter(machine_id=selected)
    machines = runs.overview()
    # the current builds and the failed builds not followed by a success, in one query
    shown = list(Build.objects.filter(Q(current=True) | Q(pk__in=Build.objects.unresolved_failures().values("pk")))
                 .select_related("target", "machine").defer("log", "environment"))
    builds = {(b.machine_id, b.target_id): b for b in shown if b.current}
    failed_builds = sorted((b for b in shown if b.status == Build.Status.FAILED),
                           key=lambda b: (b.machine.name, b.target.name, -(b.finished.timestamp() if b.finished else 0)))
    if selected is not None:
        failed_builds = [b for b in failed_builds if b.machine_id == selected]
    commit_urls = {pk: (definition or {}).get("commit_url")
                   for pk, definition in Target.objects.values_list("pk", "definition")}
    speed = stepping_changes(builds.values())
    totals = {(row["machine_id"], row["target_id"]): row for row in everything.values(
        "machine_id", "machine__name", "target_id", "target__name").annotate(n=Count("id")).order_by()}
    for machine in machines:
        for target in machine["targets"]:
            key = (machine["machine_id"], target["target_id"])
            target["build"] = build = builds.get(key)
            target["older"] = totals.pop(key)["n"] - target["tally"].total
            if build is not None:
                target["commit"] = presentation.commit_link(build, commit_urls.get(target["target_id"]))
                target["speed"] = speed.get(build.pk)
        machine["targets"].sort(key=lambda t: (presentation.VERDICT_ORDER[t["tally"].verdict], t["target"]))
    # targets with runs, none of them by their current build: named, so that no result silently vanishes
    uncounted = sorted(({"machine": r["machine__name"], "machine_id": r["machine_id"], "target": r["target__name"],
                         "target_id": r["target_id"], "runs": r["n"], "build": builds.get(key)}
                        for key, r in totals.items()), key=lambda u: (u["machine"], u["target"]))
    # a search lists the runs it found, not only their counts
    page = _with_failing_since(_page(request, _run_list(runs.listing()))) if found["filtered"] else None
    return render(request, "webfrontend/overview.html", {
        "machines": machines, "mode": mode, "selected": selected, "uncounted": uncounted, "page": page,
        "failed_builds": failed_builds, "all_machines": Machine.objects.order_by("name"),
        "show_failing_since": True, **found})


def build_detail(request, build_id):
    """A build: state, duration, compiler, options, patches, ccache use, first error line and the log."""
    build = get_object_or_404(Build.objects.select_related("target", "machine"), pk=build_id)
    return render(request, "webfrontend/build.html", {
        "build": build, "details": build.details or {},
        "log": presentation.tail(build.log, settings.DASHBOARD_TEXT_LIMIT)})


def testcase_runs(request, testcase):
    case = get_object_or_404(TestCase, path=testcase.strip("/"))
    found = _filters(request)
    runs = Run.objects.filter(testcase=case).search(**found["filters"])
    return render(request, "webfrontend/testcase.html", {
        "testcase": case, "page": _with_failing_since(_page(request, _run_list(runs.listing()))),
        "show_failing_since": True, **found})


def folder(request, machine_id, target_id, folder=""):
    mode, show = _mode(request)
    machine = get_object_or_404(Machine, pk=machine_id)
    target = get_object_or_404(Target.objects.select_related("reference"), pk=target_id)
    build = current_build(target.name, machine.name)
    found = _filters(request)
    runs = Run.objects.filter(machine=machine, target=target).search(**found["filters"]).current()
    folder = folder.strip("/")
    children, whole = runs.folder(folder)
    testcase = None
    if not children and not whole.is_testcase and folder:
        # no run of the current build here: a test case (or folder) only older builds ran stays reachable
        testcase = TestCase.objects.filter(path=folder).first()
        if testcase is None and not Run.objects.filter(machine=machine, target=target).below(folder).exists():
            raise Http404("no test cases in this folder")
    page = _with_failing_since(_page(request, _run_list(
        runs.filter(testcase__path=whole.path).in_category(show).listing()))) if whole.is_testcase else None
    return render(request, "webfrontend/folder.html", {
        "machine": machine, "target": target, "build": build, "whole": whole, "mode": mode, "show": show,
        "children": [c for c in children if c.matches(show)], "page": page, "testcase": testcase,
        "categories": CONSISTENCY_CATEGORIES if mode == "consistency" else STATE_CATEGORIES,
        "crumbs": presentation.breadcrumbs(whole.path), "show_failing_since": True, **found})


def run_detail(request, run_id):
    run = get_object_or_404(Run.objects.detail(), pk=run_id)
    files = RunFolder(run)
    return render(request, "webfrontend/run.html", {
        "run": run, "label": presentation.run_label(run), "timings": efficiency.breakdown_rows(efficiency.timed([run])),
        "verdict": stored_verdict(run), "texts": files.texts(), "artifacts": files.artifacts(),
        "build_log": presentation.tail(run.build.log, settings.DASHBOARD_TEXT_LIMIT),
        "has_series": bool(run.series.all()), "expectations": presentation.expectation_rows(files),
        "form": OverrideForm(run), "failing_since": Run.objects.failing_since([run]).get(run.pk)})


def run_plots(request, run_id):
    """Every quantity of every series of a run and every declared plot (thesis fig. 4.4), with the run
    configuration's expectations drawn over the quantities they bound."""
    run = get_object_or_404(Run.objects.select_related("target__reference"), pk=run_id)
    reference = Run.objects.reference_for(run)
    return _plots_json(presentation.run_plots(
        run, list(Series.objects.filter(run=run)), reference,
        list(Series.objects.filter(run=reference)) if reference is not None else []))


def run_file(request, run_id, relative):
    path = RunFolder(get_object_or_404(Run, pk=run_id)).resolve(relative)
    if path is None:
        raise Http404("no such file in the run folder")
    return FileResponse(path.open("rb"), as_attachment=True, filename=path.name)


def _compared(ids: list[int]) -> list:
    """Runs by id in the order asked (unknown ids dropped), with what the comparison shows - not their
    series, which stay in the database until a plot asks for them, nor their builds' logs (each row would
    carry its own copy)."""
    runs = {r.pk: r for r in Run.objects.filter(pk__in=ids).select_related(
        "build", "target", "machine", "testcase", "reference_run__build", "reference_run__target").defer(
        "build__log", "reference_run__build__log").with_accepted()}
    return [runs[i] for i in ids if i in runs]


def _comparison(runs) -> dict:
    """What a comparison page shows of ``runs``; the files are read only for the diff of exactly two runs."""
    diffs = []
    if len(runs) == 2:
        texts = [RunFolder(r).texts() for r in runs]
        diffs = presentation.text_diffs(runs[0], texts[0], runs[1], texts[1])
    return {"runs": runs, "compared": [(r, presentation.run_label(r)) for r in runs],
            "diff_count": sum(not d["equal"] for d in diffs),
            "timings": efficiency.breakdown_rows(efficiency.timed(runs)), "diffs": diffs, "compare_limit": COMPARE_LIMIT,
            "contents": len({r.testcase_hash for r in runs}),
            "plots_url": reverse("compare-plots") + "?" + urlencode({"run": ",".join(str(r.pk) for r in runs)})
            if len(runs) > 1 else None}


def compare(request):
    """Runs side by side against one of them, the reference: the one ``reference=ID`` names, else a run of
    the reference target of another compared run's target, else the first. The reference comes first: the
    bands are drawn around it and the diffs go from it to the other run."""
    runs = _compared(params.id_list(request.GET, "run", COMPARE_LIMIT, "runs"))
    reference = presentation.choose_reference(runs, params.optional_id(request.GET, "reference"))
    if reference is not None:
        runs = [reference] + [r for r in runs if r is not reference]
    return render(request, "webfrontend/compare.html", {
        **_comparison(runs), "compare_reference": reference,
        "reference_links": [(r, "?" + urlencode([("run", x.pk) for x in runs] + [("reference", r.pk)]))
                            for r in runs if r is not reference]})


def compare_plots(request):
    """Plots of compared runs: overlaid, and for two runs the consistency bands of the second around the
    first and its deviation, for more the difference of each to the first."""
    ids = params.id_list(request.GET, "run", COMPARE_LIMIT, "runs")
    if len(ids) < 2:
        raise params.BadParameter("run: two or more runs are compared")
    runs = Run.objects.filter(pk__in=ids).select_related("target", "build", "machine", "testcase")
    by_id = {r.pk: r for r in runs}
    runs = [by_id[i] for i in ids if i in by_id]
    if len(runs) < 2:
        raise Http404("fewer than two of these runs exist")
    return _plots_json(presentation.compare_plots(runs, Series.objects.filter(run__in=runs)))


def consistency(request, run_id):
    run = get_object_or_404(Run.objects.detail(), pk=run_id)
    reference = Run.objects.reference_for(run)
    runs = [r for r in (reference, run) if r is not None]
    return render(request, "webfrontend/compare.html", {
        **_comparison(runs), "consistency_run": run, "reference": reference, "verdict": stored_verdict(run),
        "results": run.consistency_results.all(), "form": OverrideForm(run)})


def consistency_plots(request, run_id):
    """The run's trajectories over its reference's with the acceptance bands, one per stored result."""
    results = list(ConsistencyResult.objects.filter(run_id=run_id).select_related(
        "run__target", "run__build", "reference_run__target", "reference_run__build").order_by("value", "pk"))
    if not results and not Run.objects.filter(pk=run_id).exists():
        raise Http404("no such run")
    return _plots_json(presentation.consistency_plots(results))


@login_required
@require_POST
def override(request, run_id):
    run = get_object_or_404(Run.objects.prefetch_related("consistency_results"), pk=run_id)
    form = OverrideForm(run, request.POST)
    if form.is_valid():
        Override.objects.create(run=run, user=request.user, quantity=form.cleaned_data["quantity"],
                                reason=form.cleaned_data["reason"])
        messages.success(request, f"Run #{run.pk} overruled by {request.user.get_username()}.")
    else:
        messages.error(request, "Not overruled: " + "; ".join(
            f"{name}: {' '.join(errors)}" for name, errors in form.errors.items()))
    return redirect("consistency" if request.POST.get("next") == "consistency" else "run", run.pk)


def _history_runs(request, target_id, testcase):
    target = get_object_or_404(Target, pk=target_id)
    case = get_object_or_404(TestCase, path=testcase.strip("/"))
    machine_id = params.optional_id(request.GET, "machine")
    return target, case, machine_id, Run.objects.history(target, case, machine_id)


def history(request, target_id, testcase):
    target, case, machine_id, runs = _history_runs(request, target_id, testcase)
    runs = runs.select_related("target", "testcase")
    return render(request, "webfrontend/history.html", {
        "target": target, "testcase": case, "page": _page(request, _run_list(runs)),
        "machine_id": machine_id or "", "c_floor": plots.C_AXIS_FLOOR})


def history_plots(request, target_id, testcase):
    """C, stepping time and wall time of the test case over the commits of the target, with the commits
    harness.analysis.regressions marks (on the machine named, else the machine of the newest run)."""
    target, case, machine_id, runs = _history_runs(request, target_id, testcase)
    if machine_id is not None:
        machine = get_object_or_404(Machine, pk=machine_id)
    else:
        newest = runs.order_by("-id").values_list("machine_id", flat=True).first()
        machine = Machine.objects.filter(pk=newest).first() if newest else None
    if machine is None:
        raise Http404("no runs")
    return _plots_json(presentation.history_plots(target, case, machine))


def regressions(request):
    """The commits where a test case's stepping time or a quantity changed (harness.analysis.regressions.histories,
    as ``harness regressions`` prints them), on one machine, optionally of one target and ``-k`` pattern."""
    # every parameter is read before the store is asked which machine: a malformed one is named whatever it holds
    target_id = params.optional_id(request.GET, "target")
    pattern = params.text(request.GET, "k")
    machine = _one_machine(request, "regressions")
    target = get_object_or_404(Target, pk=target_id) if target_id else None
    found = histories(machine.name, target.name if target else None, pattern) if machine else []
    return render(request, "webfrontend/regressions.html", {
        "machine": machine, "target": target, "pattern": pattern or "", "histories": len(found),
        "comparable": comparable(found),
        "changes": presentation.regression_rows(found, machine),
        "targets": Target.objects.order_by("name"), "machines": Machine.objects.order_by("name")})


def _one_machine(request, view: str):
    """The machine a per-machine page is about: the one named, or the store's only one (None: no machines);
    with several and none named, a 400 offering each."""
    machine_id = params.optional_id(request.GET, "machine")
    if machine_id is not None:
        return get_object_or_404(Machine, pk=machine_id)
    machines = list(Machine.objects.order_by("name"))
    if len(machines) > 1:
        raise params.BadParameter(f"machine: the store holds runs of {len(machines)} machines; name one",
                                  links=[(m.name, reverse(view) + "?" + urlencode({"machine": m.pk}))
                                         for m in machines])
    return machines[0] if machines else None


def sweeps(request):
    return render(request, "webfrontend/sweeps.html", {"sweeps": current_sweeps()})


def sweep_plots(request, build_id, testcase, name):
    """A sweep's error against run time and against the swept value, from the store (no image drawn)."""
    build = get_object_or_404(Build.objects.select_related("target"), pk=build_id)
    result = find_sweep(build, testcase, name)
    if result is None:
        raise Http404("no such sweep")
    return _plots_json(plots.sweep_plots(result.table, result.spec,
                                         f"{build.target.name}: {result.testcase}/{result.name}"))


def _build_choices():
    """Complete builds to compare, grouped by machine and target, newest commit first (bounded: a store with
    thousands of builds lists the newest ``BUILD_CHOICE_LIMIT``)."""
    builds = (Build.objects.filter(status=Build.Status.COMPLETE).select_related("target", "machine")
              .only("id", "revision", "commit", "committed_at", "current", "target__name", "machine__name")
              .order_by("machine__name", "target__name", "-committed_at", "-id")[:BUILD_CHOICE_LIMIT])
    groups: dict = {}
    for build in builds:
        groups.setdefault(f"{build.target.name} on {build.machine.name}", []).append(build)
    return groups


#: rows of a build comparison shown on its page (the worst first); the CLI's --json lists all
COMPARE_ROWS_SHOWN = 200


def commit_page(request, target, commit):
    """What a commit did to a target: its build on one machine (``?machine=NAME``, else the machine of its newest
    build of that commit), the verdict of its runs, and against the build of the commit before (history order):
    new failures, fixes, inconsistencies and the stepping-time change - what ``harness compare`` prints."""
    target_row = get_object_or_404(Target, name=target)
    builds = Build.objects.filter(target=target_row, commit__startswith=commit.lower()).select_related(
        "machine", "target").defer("log")
    machine_name = params.text(request.GET, "machine")
    if machine_name:
        builds = builds.filter(machine__name=machine_name)
    build = builds.order_by("-current", "-started", "-id").first()
    if build is None:
        raise Http404("no build of this commit")
    tally = fold_into_children(Run.objects.filter(build=build, replaced=False).outcome_rows(), "")[1]
    previous = previous_builds([build])[build.pk]
    context = {"build": build, "tally": tally, "previous": previous, "target": target_row,
               "commit": presentation.commit_link(build, (target_row.definition or {}).get("commit_url"))}
    if previous is not None:
        previous = Build.objects.select_related("target", "machine").defer("log").get(pk=previous.pk)
        comparison = compare_builds(previous, build, build.machine.name, presentation.build_label(previous),
                                    presentation.build_label(build))
        context.update({"a": previous, "b": build, "comparison": comparison, "summary": summary(comparison),
                        "counts": comparison.counts(), "header": HEADER, "previous": previous,
                        "rows": presentation.comparison_rows(comparison, COMPARE_ROWS_SHOWN),
                        "hidden_rows": len(comparison.pairs) - COMPARE_ROWS_SHOWN})
    return render(request, "webfrontend/commit.html", context)


def _reference_and_current() -> tuple[int, int] | None:
    """(reference build, current build) ids: of the most recently built target that names a reference target,
    its current build and its reference target's current build on the same machine (None: no such pair)."""
    currents = list(Build.objects.filter(current=True, status=Build.Status.COMPLETE)
                    .select_related("target").only("id", "machine_id", "target_id", "target__reference_id",
                                                   "committed_at", "started")
                    .order_by("-started", "-committed_at", "-id"))
    by_key = {(b.machine_id, b.target_id): b.pk for b in currents}
    for build in currents:
        reference = by_key.get((build.machine_id, build.target.reference_id))
        if build.target.reference_id and reference is not None:
            return reference, build.pk
    return None


def compare_builds_page(request):
    """Two builds side by side: what ``harness compare A B`` prints (harness.analysis.compare.compare_builds), each row
    linking to the two runs' comparison with the consistency bands of B around A."""
    a_id, b_id = params.optional_id(request.GET, "a"), params.optional_id(request.GET, "b")
    defaulted = a_id is None and b_id is None
    if defaulted:
        # nothing asked: the current build of the newest target with a reference against its reference's
        a_id, b_id = _reference_and_current() or (None, None)
    context = {"choices": _build_choices(), "a_id": a_id, "b_id": b_id, "defaulted": defaulted and a_id is not None}
    if a_id is not None and b_id is not None:
        builds = Build.objects.select_related("target", "machine").defer("log")
        a, b = get_object_or_404(builds, pk=a_id), get_object_or_404(builds, pk=b_id)
        if a.machine_id != b.machine_id:
            raise params.BadParameter(f"b: build #{b.pk} ran on {b.machine.name}, build #{a.pk} on "
                                      f"{a.machine.name}; runs are compared on one machine")
        comparison = compare_builds(a, b, a.machine.name, presentation.build_label(a), presentation.build_label(b))
        # worst first; a page of ten thousand consistent rows helps nobody and takes seconds to draw
        context.update({"a": a, "b": b, "comparison": comparison, "summary": summary(comparison),
                        "counts": comparison.counts(), "header": HEADER,
                        "rows": presentation.comparison_rows(comparison, COMPARE_ROWS_SHOWN),
                        "hidden_rows": len(comparison.pairs) - COMPARE_ROWS_SHOWN})
    elif a_id is not None or b_id is not None:
        raise params.BadParameter("a and b: name both builds to compare")
    return render(request, "webfrontend/compare_builds.html", context)


def junit(request):
    """JUnit XML of the current builds' runs by harness.analysis.check's writer: what `harness check --junit` writes
    for the same runs. One machine per report, as the CLI writes it (runs of two machines would collide)."""
    machine = params.optional_id(request.GET, "machine")
    target = params.optional_id(request.GET, "target")
    if machine is None:
        machines = list(Machine.objects.filter(Q(runs__build__current=True) & Q(runs__replaced=False))
                        .distinct().order_by("name"))
        if len(machines) > 1:
            query = {"target": target} if target else {}
            raise params.BadParameter(
                f"machine: the store holds runs of {len(machines)} machines and a JUnit report is per machine "
                "(as 'harness check' writes it); name one", links=[
                    (m.name, reverse("junit") + "?" + urlencode({"machine": m.pk, **query})) for m in machines])
        machine = machines[0].pk if machines else None
    # ?allow_missing=1: runs not executed are skipped, as `harness check --allow-missing` writes them
    allow_missing = params.choice(request.GET, "allow_missing", ("0", "1"), "0") == "1"
    response = HttpResponse(stored_junit_xml(covered_runs(machine, target), allow_missing,
                                             failed_current_builds(machine, target)),
                            content_type="application/xml")
    response["Content-Disposition"] = 'attachment; filename="junit.xml"'
    return response


#: targets one matrix compares at most (each pair of them is scored on every run they share)
MATRIX_TARGET_LIMIT = 12


def _matrix(request):
    """(machine, target names, -k pattern, harness.analysis.matrix.Matrix or None) of a matrix request: the targets
    named (``?target=ID``, in that order), else those named ``*-crosscode`` as ``harness matrix`` takes them."""
    ids = params.id_list(request.GET, "target", MATRIX_TARGET_LIMIT, "targets")
    pattern = params.text(request.GET, "k")
    machine = _one_machine(request, "matrix")   # after the parameters, as in regressions()
    if ids:
        found = dict(Target.objects.filter(pk__in=ids).values_list("pk", "name"))
        missing = [i for i in ids if i not in found]
        if missing:
            raise Http404(f"no target #{missing[0]}")
        if len(ids) < 2:
            raise params.BadParameter("target: the matrix needs at least two targets; name another")
        names = [found[i] for i in ids]
    else:
        names = list(Target.objects.filter(name__endswith="-crosscode").order_by("name")
                     .values_list("name", flat=True))
    if machine is None or len(names) < 2:
        return machine, names, pattern, None
    builds = {name: current_build(name, machine.name) for name in names}
    return machine, names, pattern, build_matrix(builds, machine.name, pattern)


def matrix(request):
    """The cross-code consistency matrix (harness.analysis.matrix.build_matrix, what ``harness matrix`` prints): C of
    every target's run against every other target's run of the same test case content, per quantity; each
    cell links to the comparison of the two runs with the code's run in the bands around the reference's."""
    machine, names, pattern, result = _matrix(request)
    blocks, lowest = [], []
    if result is not None:
        blocks = presentation.matrix_blocks(result, Run.objects.matrix_runs(names, machine.name))
        lowest = [{"code": code, "reference": reference, "cell": cell, "text": _c(cell.value)}
                  for (code, reference), cell in sorted(result.lowest().items())]
    chosen = list(Target.objects.filter(name__in=names).values_list("pk", flat=True))
    query = {"machine": machine.pk} if machine else {}
    query.update({key: request.GET.getlist(key) for key in ("target", "k") if request.GET.get(key)})
    return render(request, "webfrontend/matrix.html", {
        "machine": machine, "names": names, "pattern": pattern or "", "matrix": result, "blocks": blocks,
        "lowest": lowest, "chosen": chosen, "targets": Target.objects.order_by("name"),
        "machines": Machine.objects.order_by("name"),
        "json_url": reverse("matrix-json") + ("?" + urlencode(query, doseq=True) if query else "")})


def matrix_json(request):
    """The matrix as ``harness matrix --json`` writes it (harness.analysis.matrix.to_json)."""
    _, names, _, result = _matrix(request)
    return JsonResponse(to_json(result if result is not None else Matrix(names)),
                        json_dumps_params={"allow_nan": False})
