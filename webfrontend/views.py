"""Views of the dashboard (thesis 4.6): each a query (harness/queries.py) and a render.

Anonymous users read everything; only a logged-in user may overrule (POST with CSRF token).
"""
from __future__ import annotations

from django.contrib import messages
from django.contrib.auth.decorators import login_required
from django.http import FileResponse, Http404, HttpResponse
from django.shortcuts import get_object_or_404, redirect, render
from django.views.decorators.http import require_POST

from harness.models import ConsistencyResult, Machine, Override, Run, Series, Target, TestCase
from harness.queries import CONSISTENCY_CATEGORIES, STATE_CATEGORIES
from webfrontend import plots, presentation
from webfrontend.forms import OverrideForm
from webfrontend.junit import junit_xml
from webfrontend.runfiles import RunFolder


def _mode(request) -> tuple[str, str | None]:
    """(mode, category filter) from the query string; unknown values are ignored."""
    mode = "consistency" if request.GET.get("mode") == "consistency" else "state"
    show = request.GET.get("show")
    allowed = CONSISTENCY_CATEGORIES if mode == "consistency" else STATE_CATEGORIES
    return mode, show if show in allowed else None


def _ids(request, key="run") -> list[int]:
    ids = []
    for value in request.GET.getlist(key):
        for part in value.split(","):
            if part.strip().isdigit():
                ids.append(int(part))
    return ids


def _png(fig) -> HttpResponse:
    response = HttpResponse(plots.png(fig), content_type="image/png")
    response["Cache-Control"] = "max-age=60"
    return response


def overview(request):
    mode, _ = _mode(request)
    selected = request.GET.get("machine", "")
    runs = Run.objects.filter(machine_id=selected) if selected.isdigit() else Run.objects.all()
    return render(request, "webfrontend/overview.html", {
        "machines": runs.overview(), "mode": mode, "selected": selected,
        "all_machines": Machine.objects.order_by("name")})


def testcase_runs(request, testcase):
    case = get_object_or_404(TestCase, path=testcase.strip("/"))
    return render(request, "webfrontend/testcase.html", {
        "testcase": case, "runs": Run.objects.filter(testcase=case).listing()})


def folder(request, machine_id, target_id, folder=""):
    mode, show = _mode(request)
    machine = get_object_or_404(Machine, pk=machine_id)
    target = get_object_or_404(Target.objects.select_related("reference"), pk=target_id)
    runs = Run.objects.filter(machine=machine, target=target)
    children, whole = runs.folder(folder.strip("/"))
    if not children and not whole.is_testcase:
        raise Http404("no test cases in this folder")
    listed = runs.filter(testcase__path=whole.path).in_category(show).listing() if whole.is_testcase else []
    return render(request, "webfrontend/folder.html", {
        "machine": machine, "target": target, "whole": whole, "mode": mode, "show": show,
        "children": [c for c in children if c.matches(show)], "runs": listed,
        "categories": CONSISTENCY_CATEGORIES if mode == "consistency" else STATE_CATEGORIES,
        "crumbs": presentation.breadcrumbs(whole.path)})


def run_detail(request, run_id):
    run = get_object_or_404(Run.objects.detail(), pk=run_id)
    return render(request, "webfrontend/run.html", {
        "run": run, "label": presentation.run_label(run), "timings": [presentation.timing_bar(run)],
        "texts": RunFolder(run).texts(), "artifacts": RunFolder(run).artifacts(),
        "plots": presentation.run_plots(run), "form": OverrideForm(run)})


def run_plot(request, run_id, series_id):
    series = get_object_or_404(Series, pk=series_id, run_id=run_id)
    quantity = request.GET.get("q") or None
    if quantity is not None and quantity not in plots.quantities(series):
        raise Http404("no such quantity")
    if quantity is None and series.kind != "plot":
        quantity = (plots.quantities(series) or [None])[0]
    if not plots.quantities(series):
        raise Http404("nothing to plot")
    return _png(plots.series_figure([(f"#{run_id}", series)], quantity))


def run_file(request, run_id, relative):
    path = RunFolder(get_object_or_404(Run, pk=run_id)).resolve(relative)
    if path is None:
        raise Http404("no such file in the run folder")
    return FileResponse(path.open("rb"), as_attachment=True, filename=path.name)


def compare(request):
    runs = Run.objects.selected(_ids(request))
    texts = [RunFolder(r).texts() for r in runs]
    return render(request, "webfrontend/compare.html", {
        "runs": runs, "compared": [(r, presentation.run_label(r)) for r in runs],
        "timings": presentation.timing_bars(runs),
        "diffs": presentation.text_diffs(runs[0], texts[0], runs[1], texts[1]) if len(runs) == 2 else [],
        "plots": presentation.compare_plots(runs, Series.objects.shared_by(runs))})


def compare_plot(request):
    ids = _ids(request)
    quantity = request.GET.get("q") or None
    series = Series.objects.filter(run_id__in=ids, kind=request.GET.get("kind", ""),
                                   name=request.GET.get("name", "")).select_related(
        "run__target", "run__build", "run__machine", "run__testcase")
    by_run = {s.run_id: s for s in series}
    curves = [(presentation.short_label(by_run[i].run), by_run[i]) for i in dict.fromkeys(ids) if i in by_run]
    if not curves or (quantity and quantity not in plots.quantities(curves[0][1])):
        raise Http404("no such series")
    return _png(plots.series_figure(curves, quantity or (None if curves[0][1].kind == "plot"
                                                         else plots.quantities(curves[0][1])[0])))


def consistency(request, run_id):
    run = get_object_or_404(Run.objects.detail(), pk=run_id)
    reference = Run.objects.reference_for(run)
    runs = [r for r in (reference, run) if r is not None]
    texts = [RunFolder(r).texts() for r in runs]
    return render(request, "webfrontend/compare.html", {
        "consistency_run": run, "reference": reference, "runs": runs,
        "compared": [(r, presentation.run_label(r)) for r in runs], "timings": presentation.timing_bars(runs),
        "results": run.consistency_results.all(), "form": OverrideForm(run),
        "diffs": presentation.text_diffs(runs[0], texts[0], runs[1], texts[1]) if len(runs) == 2 else [],
        "plots": presentation.compare_plots(runs, Series.objects.shared_by(runs))})


def consistency_plot(request, run_id, result_id):
    result = get_object_or_404(ConsistencyResult.objects.select_related(
        "run__target", "run__build", "run__machine", "run__testcase", "reference_run__target",
        "reference_run__build", "reference_run__machine", "reference_run__testcase"), pk=result_id, run_id=run_id)
    pair = Series.objects.filter(run_id__in=[result.run_id, result.reference_run_id], kind=result.series_kind,
                                 name=result.series_name)
    by_run = {s.run_id: s for s in pair}
    if result.reference_run_id not in by_run:
        raise Http404("the reference run has no such series")
    return _png(plots.consistency_figure(result, by_run.get(result.run_id), by_run[result.reference_run_id],
                                         presentation.short_label(result.run),
                                         presentation.short_label(result.reference_run)))


@login_required
@require_POST
def override(request, run_id):
    run = get_object_or_404(Run.objects.detail(), pk=run_id)
    form = OverrideForm(run, request.POST)
    if form.is_valid():
        Override.objects.create(run=run, user=request.user, quantity=form.cleaned_data["quantity"],
                                reason=form.cleaned_data["reason"])
        messages.success(request, f"Run #{run.pk} overruled by {request.user.get_username()}.")
    else:
        messages.error(request, "Not overruled: " + "; ".join(
            f"{name}: {' '.join(errors)}" for name, errors in form.errors.items()))
    return redirect("consistency" if request.POST.get("next") == "consistency" else "run", run.pk)


def history(request, target_id, testcase):
    target = get_object_or_404(Target, pk=target_id)
    case = get_object_or_404(TestCase, path=testcase.strip("/"))
    machine_id = request.GET.get("machine")
    runs = Run.objects.history(target, case, machine_id if machine_id and machine_id.isdigit() else None)
    return render(request, "webfrontend/history.html", {
        "target": target, "testcase": case, "runs": runs, "machine_id": machine_id or ""})


def history_plot(request, target_id, testcase):
    target = get_object_or_404(Target, pk=target_id)
    case = get_object_or_404(TestCase, path=testcase.strip("/"))
    machine_id = request.GET.get("machine")
    runs = list(Run.objects.history(target, case, machine_id if machine_id and machine_id.isdigit() else None))
    if not runs:
        raise Http404("no runs")
    return _png(plots.history_figure(runs, case.path, target.name))


def sweeps(request):
    from harness.sweep import current_sweeps

    return render(request, "webfrontend/sweeps.html", {"sweeps": current_sweeps()})


def sweep_plot(request, build_id, testcase, name):
    from io import BytesIO

    from harness.models import Build
    from harness.sweep import find_sweep, plot

    build = get_object_or_404(Build.objects.select_related("target"), pk=build_id)
    result = find_sweep(build, testcase.strip("/"), name)
    if result is None:
        raise Http404("no such sweep")
    out = BytesIO()
    plot(result.table, result.spec, f"{build.target.name}: {result.testcase}/{result.name}", out)
    response = HttpResponse(out.getvalue(), content_type="image/png")
    response["Cache-Control"] = "max-age=60"
    return response


def junit(request):
    runs = Run.objects.junit(*(request.GET.get(k) if (request.GET.get(k) or "").isdigit() else None
                               for k in ("machine", "target")))
    response = HttpResponse(junit_xml(runs), content_type="application/xml")
    response["Content-Disposition"] = 'attachment; filename="junit.xml"'
    return response
