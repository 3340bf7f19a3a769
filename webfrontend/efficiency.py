"""Dashboard pages of efficiency (thesis part II): scaling studies and their history over commits, timing
breakdowns as stacked bars over the commits of a target, and profiles as flame graphs (one run, or two as a
differential flame graph). Views stay thin: the figures come from ``harness.analysis.scaling``, ``harness.analysis.breakdown``
and ``harness.execution.profiles``, the same functions ``harness scaling``, ``compare --profile`` and ``bisect`` use.
"""
from __future__ import annotations

from collections import Counter

from django.http import Http404, JsonResponse
from django.shortcuts import get_object_or_404, render
from django.urls import reverse

from harness.analysis import breakdown as bd
from harness.analysis import scaling
from harness.execution import profiles
from harness.store.models import Build, Machine, Run, Target, TestCase
from webfrontend import params, plots

#: colours of the sections, in harness.analysis.breakdown.SECTIONS order (the stacked bars of parts/timing.html,
#: the breakdown page and the table's swatches)
SECTION_COLORS = dict(zip(bd.SECTIONS, ("#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#7f7f7f")))
#: the top of the efficiency plot's axis (efficiency and serial fraction are fractions; larger values are drawn
#: there, their value on hover)
EFFICIENCY_AXIS_TOP = 1.5
#: commits one breakdown page draws at most per run name (the newest)
BREAKDOWN_COMMITS = 200


def section_bar(breakdown: dict, scale: float) -> list[dict]:
    """Segments of one stacked bar: section, seconds, percent of ``scale`` (s), colour."""
    seconds = bd.section_seconds(breakdown)
    return [{"section": name, "seconds": value, "percent": 100.0 * value / scale, "color": SECTION_COLORS[name]}
            for name, value in seconds.items() if value > 0 and scale > 0]


def timed(runs) -> list:
    """The runs that have a timing breakdown (``harness.analysis.breakdown.of_run``): the others draw no bar."""
    return [r for r in runs if bd.of_run(r)]


def breakdown_rows(runs) -> list[dict]:
    """Per run: its stacked bar (one scale for all, so a slower run has a longer bar), the sections with
    min/avg/max over ranks, ranks and load imbalance."""
    data = [bd.of_run(r) for r in runs]
    totals = [d.get("total") or sum(bd.section_seconds(d).values()) for d in data]
    scale = max(totals, default=0.0)
    rows = []
    for run, total, data in zip(runs, totals, data):
        sections = data.get("sections", {})
        rows.append({"run": run, "total": total, "width": 100.0 * total / scale if scale else 0.0,
                     "segments": section_bar(data, scale), "ranks": data.get("ranks"),
                     "imbalance": data.get("imbalance"), "imbalance_of": data.get("imbalance_of", ""),
                     "sections": [(name, sections.get(name, {})) for name in bd.SECTIONS]})
    return rows


# ----------------------------------------------------------------------------------------------- scaling

def scaling_page(request):
    """Scaling studies of the current build of every target (per machine), and per target the efficiency at
    the most cores over its commits: a revision that scales worse shows even when one-core speed holds."""
    machine_id = params.optional_id(request.GET, "machine")
    build_id = params.optional_id(request.GET, "build")  # one revision's studies instead of the current ones
    chosen = {"pk": build_id} if build_id is not None else {"current": True}
    builds = (Build.objects.filter(status=Build.Status.COMPLETE, runs__config__has_key="scaling_point", **chosen)
              .select_related("target", "machine").defer("log").distinct().order_by("machine__name", "target__name"))
    if machine_id is not None:
        builds = builds.filter(machine_id=machine_id)
    sections = []
    for build in builds:
        runs = Run.objects.filter(build=build, machine=build.machine, replaced=False)
        studies = scaling.studies_in_store(runs)
        history = scaling.history(build.target_id, build.machine_id)
        sections.append({"build": build, "studies": [
            {"study": s, "history": [dict(row, bar=100.0 * min(1.0, max(0.0, row["efficiency"] or 0.0)))
                                     for row in history.get(s.key, [])]} for s in studies]})
    return render(request, "webfrontend/scaling.html", {"sections": sections, "build_id": build_id,
                                                        "machines": Machine.objects.order_by("name")})


def scaling_plots(request, build_id, testcase, name):
    """Two plots of a study: speedup against cores with the ideal line (S = P), and the efficiency at the most
    cores over the target's commits (oldest first)."""
    build = get_object_or_404(Build.objects.select_related("target").defer("log"), pk=build_id)
    runs = Run.objects.filter(build=build, testcase__path=testcase, replaced=False)
    study = next((s for s in scaling.studies_in_store(runs) if s.name == name), None)
    if study is None:
        raise Http404("no such scaling study")
    cores = [p.cores for p in study.points]
    base = cores[0]
    title = f"{build.target.name}: {study.key}"
    # core counts are whole numbers: one tick per measured count (no "1.5 cores")
    speedup = plots.plot(f"{title}: speedup ({study.kind} scaling)", "cores", "speedup [1]",
                         list(range(len(cores))), [
        {"label": "measured", "values": [p.speedup for p in study.points], "color": plots.PALETTE[0], "points": True},
        {"label": "ideal (S = P)", "values": [c / base for c in cores], "color": "#888888", "dash": True}],
        xticks=[str(c) for c in cores])
    history = scaling.history(build.target_id, build.machine_id).get(study.key, [])
    efficiency_values = [r["efficiency"] for r in history]
    serial_values = [r["serial_fraction"] for r in history]
    # both are fractions: the axis stays near [0, 1]; a serial fraction of 20 (a point slower on more cores)
    # is drawn at the top and shows its value on hover, instead of flattening the efficiency to 0
    top = min(EFFICIENCY_AXIS_TOP, max([1.05] + [v for v in efficiency_values + serial_values if v is not None]))

    def clipped(values):
        return [None if v is None else min(v, top) for v in values]

    efficiency = plots.plot(f"{title}: efficiency at the most cores per commit", "commit (oldest first)",
                            "parallel efficiency [1]", list(range(len(history))), [
        {"label": "efficiency", "values": clipped(efficiency_values), "hover": efficiency_values,
         "color": plots.PALETTE[1], "points": True},
        {"label": "serial fraction", "values": clipped(serial_values), "hover": serial_values,
         "color": plots.PALETTE[2], "points": True, "dash": True}],
        xticks=[r["commit"][:10] for r in history], ylimits=[0.0, top])
    return JsonResponse({"plots": [speedup, efficiency]})


# ---------------------------------------------------------------------------------------------- breakdown

def breakdown_history(request, target_id, testcase):
    """The timing breakdown of each run of a test case over the commits of a target: stacked bars, oldest
    commit first, one group per run name (on one machine: ``?machine=``, else every machine)."""
    target = get_object_or_404(Target, pk=target_id)
    case = get_object_or_404(TestCase, path=testcase.strip("/"))
    machine_id = params.optional_id(request.GET, "machine")
    runs = Run.objects.filter(target=target, testcase=case).exclude(breakdown={})
    if machine_id is not None:
        runs = runs.filter(machine_id=machine_id)
    runs = (runs.select_related("build", "machine")
            .only("id", "name", "state", "breakdown", "profile", "stepping_time", "machine__name", "build__commit",
                  "build__committed_at", "build__started", "build__commit_message")
            .order_by("name", "-build__committed_at", "-build__started", "-build_id"))
    groups: dict[str, list] = {}
    for run in runs:
        members = groups.setdefault(run.name, [])
        if len(members) < BREAKDOWN_COMMITS:
            members.append(run)
    shown = []
    for name, members in sorted(groups.items()):
        rows = breakdown_rows(members[::-1])
        previous = None
        for row in rows:  # a profiled run links to the differential flame graph against the previous profiled one
            row["diff_url"] = (reverse("profile-diff") + f"?run={previous.pk},{row['run'].pk}"
                               if previous is not None and row["run"].profile else None)
            previous = row["run"] if row["run"].profile else previous
        shown.append((name, rows))
    return render(request, "webfrontend/breakdown.html", {
        "target": target, "testcase": case, "machine_id": machine_id or "", "groups": shown,
        "sections": list(SECTION_COLORS.items()), "limit": BREAKDOWN_COMMITS})


# ----------------------------------------------------------------------------------------------- profiles

def _profiled(run_id: int) -> tuple:
    run = get_object_or_404(Run.objects.select_related("build", "target", "testcase"), pk=run_id)
    stacks = profiles.run_profile(run)
    return run, stacks


def profile_page(request, run_id):
    """The flame graph of one run's profile (d3-flame-graph, shipped under static/webfrontend/vendor/)."""
    run, stacks = _profiled(run_id)
    top = profiles.function_diff(Counter(), stacks)[:25] if stacks else []
    return render(request, "webfrontend/profile.html", {
        "run": run, "other": None, "has_profile": stacks is not None, "samples": sum(stacks.values()) if stacks else 0,
        "rows": top, "data_url": reverse("run-profile-json", args=[run.pk])})


def profile_json(request, run_id):
    run, stacks = _profiled(run_id)
    if stacks is None:
        raise Http404("this run has no profile (harness run --profile)")
    return JsonResponse(profiles.tree(stacks, f"#{run.pk} {run.testcase.path}/{run.name}"))


def _pair(request) -> tuple:
    ids = params.id_list(request.GET, "run", 2, "runs")
    if len(ids) != 2:
        raise params.BadParameter("run: a differential flame graph compares exactly two runs (run=A,B)")
    (a, stacks_a), (b, stacks_b) = _profiled(ids[0]), _profiled(ids[1])
    return a, stacks_a, b, stacks_b


def profile_diff_page(request):
    """Two runs' profiles as a differential flame graph: B's stacks, red where B spends a larger share of its
    samples than A, blue where smaller; and the functions whose share grew most (``harness compare
    --profile``)."""
    a, stacks_a, b, stacks_b = _pair(request)
    both = stacks_a is not None and stacks_b is not None
    rows = profiles.function_diff(stacks_a, stacks_b)[:25] if both else []
    return render(request, "webfrontend/profile.html", {
        "run": b, "other": a, "has_profile": both, "samples": sum(stacks_b.values()) if both else 0,
        "rows": rows, "data_url": reverse("profile-diff-json") + f"?run={a.pk},{b.pk}"})


def profile_diff_json(request):
    a, stacks_a, b, stacks_b = _pair(request)
    if stacks_a is None or stacks_b is None:
        raise Http404("both runs need a profile (harness run --profile)")
    return JsonResponse(profiles.diff_tree(stacks_a, stacks_b, f"#{b.pk} against #{a.pk}"))


def breakdown_context(runs) -> dict:
    """What parts/breakdown_table.html shows for runs of a run or comparison page (with the link to the
    differential flame graph when exactly two profiled runs are compared)."""
    runs = timed(runs)
    diff_url = None
    if len(runs) == 2 and all(r.profile for r in runs):
        diff_url = reverse("profile-diff") + f"?run={runs[0].pk},{runs[1].pk}"
    return {"rows": breakdown_rows(runs), "sections": list(SECTION_COLORS.items()), "diff_url": diff_url}
