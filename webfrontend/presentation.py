"""What the pages show, computed from store objects: labels, timing bars, unified diffs, plot lists."""
from __future__ import annotations

import difflib
from dataclasses import dataclass

from django.urls import reverse
from django.utils.http import urlencode

from webfrontend import plots

#: timing categories of the breakdown (thesis figure 4.8), in stacking order, with their colors
TIMING_CATEGORIES = (("pair", "#1f77b4"), ("neigh", "#ff7f0e"), ("comm", "#2ca02c"),
                     ("modify", "#9467bd"), ("output", "#8c564b"), ("other", "#7f7f7f"))
#: lines of a unified diff shown at most (the rest is summarized)
DIFF_LINE_LIMIT = 5000


def breadcrumbs(path: str) -> list[tuple[str, str]]:
    """(name, folder path) of each level of ``a/b/c``: a, a/b, a/b/c."""
    parts = path.split("/") if path else []
    return [(name, "/".join(parts[:i + 1])) for i, name in enumerate(parts)]


def revision_label(build) -> str:
    """Short name of a build for lists and plot axes: the revision as asked and the commit."""
    commit = (build.commit or "")[:7]
    if build.revision and build.revision not in ("HEAD", build.commit):
        return f"{build.revision} ({commit})"
    return commit or build.revision


def tail(text: str, limit: int) -> dict:
    """The last ``limit`` characters of a long text (a build log ends with its error), and whether it was cut."""
    text = text or ""
    return {"text": text[-limit:] if len(text) > limit else text, "cut": len(text) > limit, "length": len(text)}


def provenance(run) -> dict:
    """What a run's verdict was computed on, in short forms: the target's commit, the test case content
    hash and the reference run (its target and commit), with harness.check's one-line text as ``text``."""
    from harness.check import provenance as provenance_text

    reference = run.reference_run if run.reference_run_id else None
    return {"commit": (run.build.commit or "")[:10], "testcase": run.short_hash,
            "reference": reference, "reference_commit": (reference.build.commit or "")[:10] if reference else "",
            "text": provenance_text(run)}


def run_label(run) -> str:
    """One-line name of a run: id, target at revision, test case / run name, machine."""
    return f"#{run.pk} {run.target.name}@{revision_label(run.build)} {run.testcase.path}/{run.name} " \
           f"on {run.machine.name}"


def short_label(run) -> str:
    """Run name for legends and bars: id, target and revision (the id tells test cases apart)."""
    return f"#{run.pk} {run.target.name}@{revision_label(run.build)}"


def timing_total(run) -> float:
    timing = run.timing if isinstance(run.timing, dict) else {}
    total = timing.get("total")
    if isinstance(total, (int, float)) and total > 0:
        return float(total)
    return float(sum(v for k, v in timing.items() if k != "total" and isinstance(v, (int, float))))


@dataclass
class Segment:
    category: str
    seconds: float
    percent: float  # of the bar's scale
    color: str


def timing_bar(run, scale: float | None = None) -> dict:
    """Stacked bar of the timing breakdown in s; ``scale`` (s) is the full bar width, default the run's total.

    Compared runs share one scale, so a faster run has a shorter bar (thesis 4.6.2, figure 4.9).
    """
    timing = run.timing if isinstance(run.timing, dict) else {}
    total = timing_total(run)
    scale = scale or total
    segments = []
    for category, color in TIMING_CATEGORIES:
        seconds = timing.get(category) or 0.0
        if isinstance(seconds, (int, float)) and seconds > 0 and scale > 0:
            segments.append(Segment(category, float(seconds), 100.0 * seconds / scale, color))
    return {"run": run, "label": short_label(run), "title": run_label(run), "total": total, "segments": segments,
            "width": 100.0 * total / scale if scale else 0.0}


def timing_bars(runs) -> list[dict]:
    scale = max((timing_total(r) for r in runs), default=0.0)
    return [timing_bar(r, scale) for r in runs]


def unified_diff(a_name: str, a_text: str | None, b_name: str, b_text: str | None) -> list[tuple[str, str]]:
    """Lines of a unified diff as (css class, text); an empty list when both texts are equal."""
    lines = difflib.unified_diff((a_text or "").splitlines(), (b_text or "").splitlines(),
                                 fromfile=a_name, tofile=b_name, lineterm="", n=3)
    out = []
    for i, line in enumerate(lines):
        if i >= DIFF_LINE_LIMIT:
            out.append(("hunk", f"... diff cut after {DIFF_LINE_LIMIT} lines"))
            break
        if line.startswith(("+++", "---")):
            kind = "file"
        elif line.startswith("@@"):
            kind = "hunk"
        elif line.startswith("+"):
            kind = "add"
        elif line.startswith("-"):
            kind = "del"
        else:
            kind = "ctx"
        out.append((kind, line))
    return out


def text_diffs(run_a, texts_a: dict, run_b, texts_b: dict) -> list[dict]:
    """Per section (input script, run configuration, log, stdout, stderr): the unified diff of two runs."""
    out = []
    for section in texts_a:
        a, b = texts_a[section], texts_b.get(section)
        lines = unified_diff(f"#{run_a.pk} {a.name if a else '(missing)'}", a.text if a else None,
                             f"#{run_b.pk} {b.name if b else '(missing)'}", b.text if b else None)
        out.append({"section": section, "lines": lines, "equal": not lines})
    return out


def run_plots(run) -> list[dict]:
    """Plot images of a run page: every thermo/VTK quantity and every declared plot (thesis fig. 4.4)."""
    out = []
    for series in sorted(run.series.all(), key=lambda s: (s.kind != "plot", s.kind, s.name)):
        url = reverse("run-plot", args=[run.pk, series.pk])
        if series.kind == "plot":
            if plots.quantities(series):
                out.append({"title": series.meta.get("title") or series.name, "url": url,
                            "kind": series.kind})
            continue
        for quantity in plots.quantities(series):
            out.append({"title": f"{series.name}: {quantity}", "kind": series.kind,
                        "url": f"{url}?{urlencode({'q': quantity})}"})
    return out


def compare_plots(runs, shared: dict) -> list[dict]:
    """Overlaid plots of compared runs, one per quantity of every series some compared run has."""
    ids = [r.pk for r in runs]
    out = []
    for (kind, name), by_run in sorted(shared.items(), key=lambda kv: (kv[0][0] != "plot", kv[0])):
        first = next(iter(by_run.values()))
        base = {"run": [i for i in ids if i in by_run], "kind": kind, "name": name}
        present = f"{len(by_run)} of {len(ids)} runs"
        if kind == "plot":
            out.append({"title": f"{first.meta.get('title') or name} ({present})",
                        "url": reverse("compare-plot") + "?" + urlencode(base, doseq=True)})
            continue
        for quantity in plots.quantities(first):
            out.append({"title": f"{name}: {quantity} ({present})",
                        "url": reverse("compare-plot") + "?" + urlencode({**base, "q": quantity}, doseq=True)})
    return out


def build_label(build) -> str:
    """A build in a choice list and a comparison heading: target@revision (commit)."""
    return f"{build.target.name}@{revision_label(build)}"


def comparison_rows(comparison) -> list[dict]:
    """The rows of ``harness compare`` (harness.compare.rows: same cells, same order), each with its pair so a
    row can link to the two runs and their plots.

    Each row's cells come from ``rows`` over that pair alone, so that the dashboard's cells are the CLI's; the
    order is the one ``rows`` gives the whole comparison (outcome, then test case and run).
    """
    from harness.compare import Comparison, rows

    header, *table = rows(comparison)
    rank = {}
    for row in table:
        rank.setdefault(row[2], len(rank))
    out = []
    for pair in comparison.pairs:
        single = Comparison(comparison.label_a, comparison.label_b, comparison.commit_a, comparison.commit_b,
                            [pair])
        cells = rows(single)[1]
        link = None
        if pair.a is not None and pair.b is not None:
            link = reverse("compare") + "?" + urlencode({"run": [pair.a.pk, pair.b.pk]}, doseq=True)
        out.append({"pair": pair, "cells": cells, "link": link,
                    "failing": pair.outcome in ("new_failure", "inconsistent")})
    out.sort(key=lambda r: (rank[r["pair"].outcome], r["pair"].testcase, r["pair"].run))
    return out
