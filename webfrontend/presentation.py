"""What the pages show, computed from store objects: labels, timing bars, unified diffs, plot lists."""
from __future__ import annotations

import difflib
import json

from django.urls import reverse
from django.utils.http import urlencode

from harness.analysis.check import provenance as provenance_text
from harness.analysis.compare import Comparison, row_order
from harness.analysis.compare import rows as compare_rows
from harness.analysis.consistency import compare_runs
from harness.analysis.matrix import QUANTITIES, _c, _short
from harness.analysis.regressions import histories
from harness.store.models import Run, Series
from harness.store.rules import speed_kind
from webfrontend import plots
from webfrontend.runfiles import RECORD_NAME

#: lines of a unified diff shown at most (the rest is summarized)
DIFF_LINE_LIMIT = 5000


#: the order of the overview's rows: failing targets first
VERDICT_ORDER = {"failed": 0, "not_run": 1, "passed": 2}


def commit_link(build, commit_url: str | None) -> dict:
    """A build's commit for a page: the short commit, its subject (first line of the message) and the
    repository's web view of it when the target names one (``commit_url`` with ``{commit}``)."""
    subject = (build.commit_message or "").strip().splitlines()[0] if (build.commit_message or "").strip() else ""
    return {"short": build.commit[:10], "commit": build.commit, "subject": subject,
            "url": commit_url.replace("{commit}", build.commit) if commit_url else None}


def speed_change(ratio: float, noise: float = 0.0) -> dict:
    """A stepping-time ratio (now / before) for a page: "+12 %" slower, "-8 %" faster, and which; marked only
    beyond the measured spread of repeated runs ``noise`` (relative), by the rule of
    ``harness.store.rules.speed_kind``."""
    return {"text": f"{(ratio - 1.0) * 100.0:+.0f} %", "kind": speed_kind(ratio, noise),
            "noise": f"{noise * 100:.0f} %" if noise else ""}


def choose_reference(runs: list, asked: int | None):
    """The run of ``runs`` the others are compared against: the one asked for; else a run by the reference
    target of another run's target (the comparison ``harness check`` makes); else the first (None: no runs)."""
    if not runs:
        return None
    by_id = {r.pk: r for r in runs}
    if asked in by_id:
        return by_id[asked]
    references = {r.target.reference_id for r in runs if r.target.reference_id}
    return next((r for r in runs if r.target_id in references), runs[0])


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
    hash and the reference run (its target and commit), with harness.analysis.check's one-line text as ``text``."""
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


def engine_of(run) -> str | None:
    """The engine adapter of a run's target (its ``engine``: ``dem``, ``yade``, ``generic:FILE``), the name the
    harness evaluates the run's expectations with (harness/execution/execute.py); None when not recorded."""
    return (run.target.definition or {}).get("engine") or None


def run_plots(run, series, reference=None, reference_series=()) -> list[dict]:
    """Plots of a run page: every thermo/VTK quantity and every declared plot (thesis fig. 4.4), declared
    plots first, with the run configuration's expectations on the quantities they bound.

    With a ``reference`` run (the one the check scores against, ``RunQuerySet.reference_for``) every plot
    overlays it: a quantity the check scores is drawn over the reference with its 5 % and 10 % acceptance
    bands (harness.analysis.consistency.compare_runs, thesis fig. 4.11), a declared plot with the reference's curves.
    """
    consistency = (run.config or {}).get("consistency")
    by_key = {(s.kind, s.name): s for s in reference_series}
    results = {}
    if reference is not None:
        as_dicts = [{"kind": x.kind, "name": x.name, "x_column": x.x_column, "columns": x.columns}
                    for x in (*series, *reference_series)]
        ours, theirs = as_dicts[:len(series)], as_dicts[len(series):]
        results = {(r.series_kind, r.series_name, r.quantity): r for r in compare_runs(ours, theirs, consistency)}
    label, ref_label = f"#{run.pk}", (short_label(reference) if reference is not None else "")
    out = []
    for s in sorted(series, key=lambda s: (s.kind != "plot", s.kind, s.name)):
        ref = by_key.get((s.kind, s.name))
        if s.kind == "plot":
            if plots.quantities(s):
                curves = [(label, s)] + ([(f"reference: {ref_label}", ref)] if ref is not None else [])
                out.append(plots.series_plot(curves, None))
            continue
        for quantity in plots.quantities(s, consistency):
            overlays = plots.expectation_overlays(run.config, s.name, quantity, engine_of(run))
            scored = results.get((s.kind, s.name, quantity))
            if ref is not None and scored is not None and scored.value is not None:
                drawn = plots.consistency_plots(scored, s, ref, label, ref_label)[0]
                plots.add_overlays(drawn["series"], drawn["bands"], len(drawn["x"]), overlays)
                out.append(drawn)
            else:
                out.append(plots.series_plot([(label, s)], quantity, overlays))
    return out


def _series_by_run(series) -> dict:
    """``{(kind, name): {run_id: Series}}``."""
    out: dict = {}
    for s in series:
        out.setdefault((s.kind, s.name), {})[s.run_id] = s
    return out


def compare_plots(runs, series) -> list[dict]:
    """Plots of compared runs, per quantity of every series some compared run has: all runs overlaid; for
    two runs the consistency bands of the second around the first and its deviation from it
    (harness.analysis.consistency.compare_runs, the score ``harness compare`` gives), for more each run's difference
    to the first."""
    by_key = _series_by_run(series)
    out = []
    for (kind, name), by_run in sorted(by_key.items(), key=lambda kv: (kv[0][0] != "plot", kv[0])):
        if kind == "textfile":
            continue
        curves = [(short_label(r), by_run[r.pk]) for r in runs if r.pk in by_run]
        first = curves[0][1]
        if kind == "plot":
            out.append(plots.series_plot(curves, None))
        pair = len(runs) == 2 and len(curves) == 2
        results = {}
        if pair:
            a, b = (by_run[r.pk] for r in runs)
            as_dict = [{"kind": x.kind, "name": x.name, "x_column": x.x_column, "columns": x.columns}
                       for x in (a, b)]
            results = {r.quantity: r for r in compare_runs([as_dict[1]], [as_dict[0]],
                                                           (runs[1].config or {}).get("consistency"))}
        for quantity in plots.quantities(first):
            if kind != "plot":
                out.append(plots.series_plot(curves, quantity))
            if pair and quantity in results and results[quantity].value is not None:
                out += plots.consistency_plots(results[quantity], curves[1][1], curves[0][1], curves[1][0],
                                               curves[0][0])
            elif len(curves) > 1:
                difference = plots.difference_plot(curves, quantity)
                if difference:
                    out.append(difference)
    return out


def consistency_plots(results) -> list[dict]:
    """The bands of every stored consistency result of a run (thesis fig. 4.11), in two queries."""
    results = [r for r in results if r.series_kind != "textfile" and r.value is not None]
    if not results:
        return []
    run_ids = {r.run_id for r in results} | {r.reference_run_id for r in results}
    stored = {(s.run_id, s.kind, s.name): s for s in Series.objects.filter(
        run_id__in=run_ids, kind__in={r.series_kind for r in results}, name__in={r.series_name for r in results})}
    out = []
    for r in results:
        reference = stored.get((r.reference_run_id, r.series_kind, r.series_name))
        if reference is None:
            continue
        out += plots.consistency_plots(r, stored.get((r.run_id, r.series_kind, r.series_name)), reference,
                                       short_label(r.run), short_label(r.reference_run))
    return out


def _history_of(target, case, machine):
    # -k is a substring unless it holds glob characters; the test case is then matched exactly below
    pattern = None if any(c in case.path for c in "*?[") else case.path
    return [h for h in histories(machine.name, target.name, pattern) if h.testcase == case.path]


def history_plots(target, case, machine) -> list[dict]:
    """C, stepping time and wall time of a test case over the commits of a target (harness.analysis.regressions:
    its histories and the commits it marks)."""
    found = _history_of(target, case, machine)
    commits: dict[str, object] = {}
    for h in found:
        for commit, committed_at, *_ in h.points:
            commits.setdefault(commit, committed_at)
    order = sorted(commits, key=lambda c: commits[c])
    index = {c: i for i, c in enumerate(order)}
    lines: dict[str, dict] = {}
    changes = []
    for h in found:
        name = h.run if h.run not in lines else f"{h.run} (other content)"
        line = {"c": [None] * len(order), "stepping": [None] * len(order), "wall": [None] * len(order)}
        for commit, _when, stepping, wall, c, _state in h.points:
            i = index[commit]
            line["c"][i], line["stepping"][i], line["wall"][i] = c, stepping, wall
        lines[name] = line
        changes += [{"index": index[c.commit], "label": f"{c.commit[:7]} {h.run}: {c.kind}, {c.detail}"}
                    for c in h.changes]
    return plots.history_plots([c[:7] for c in order], lines, changes, f"{case.path} on {target.name}")


def regression_rows(found, machine) -> list[dict]:
    """One row per marked commit of harness.analysis.regressions.histories, newest first, linking to the run and the
    test case's history."""
    rows = []
    for h in found:
        for c in h.changes:
            when = next((p[1] for p in h.points if p[0] == c.commit), None)
            rows.append({"history": h, "change": c, "when": when})
    targets = dict(Run.objects.filter(pk__in=[r["change"].run_id for r in rows]).values_list("pk", "target_id"))
    for row in rows:
        target_id = targets.get(row["change"].run_id)
        row["history_url"] = (reverse("history", args=[target_id, row["history"].testcase]) + "?"
                              + urlencode({"machine": machine.pk})) if target_id else None
    rows.sort(key=lambda r: (r["when"] is None, r["when"]), reverse=True)
    return rows


def build_label(build) -> str:
    """A build in a choice list and a comparison heading: target@revision (commit)."""
    return f"{build.target.name}@{revision_label(build)}"


def comparison_rows(comparison, limit: int | None = None) -> list[dict]:
    """The rows of ``harness compare`` (harness.analysis.compare.rows: same cells, same order), each with its pair so a
    row can link to the two runs and their plots; the first ``limit`` of them (None: all).

    Each row's cells come from ``rows`` over that pair alone, so that the dashboard's cells are the CLI's; the
    order is the one ``rows`` gives the whole comparison (harness.analysis.compare.row_order). Only the rows shown are
    made: with 10,000 pairs, the others would cost most of the page's time.
    """
    out = []
    for pair in sorted(comparison.pairs, key=row_order)[:limit]:
        single = Comparison(comparison.label_a, comparison.label_b, comparison.commit_a, comparison.commit_b,
                            [pair])
        link = None
        if pair.a is not None and pair.b is not None:
            link = reverse("compare") + "?" + urlencode({"run": [pair.a.pk, pair.b.pk]}, doseq=True)
        out.append({"pair": pair, "cells": compare_rows(single)[1], "link": link,
                    "failing": pair.outcome in ("new_failure", "inconsistent")})
    return out


def expectation_rows(files) -> list[dict]:
    """The expectation and stability results of a run (``verdicts`` in its run.json, harness/execution/execute.py:
    ``{"ok", "reason", "message"}`` each), failed ones first; [] when the record has none or is unreadable."""
    record = files.read(RECORD_NAME)
    try:
        verdicts = json.loads(record.text).get("verdicts") if record and not record.truncated else None
    except (ValueError, AttributeError):
        return []
    rows = [{"ok": bool(v.get("ok")), "reason": str(v.get("reason", "")), "message": str(v.get("message", ""))}
            for v in verdicts or [] if isinstance(v, dict)] if isinstance(verdicts, list) else []
    return sorted(rows, key=lambda r: r["ok"])


def matrix_blocks(matrix, run_ids: dict) -> list[dict]:
    """``harness matrix``'s tables (harness.analysis.matrix.format_matrix) as rows of cells: one square table per test
    case run and quantity (rows the scored code, columns the reference), the particle count only where a cell
    is not perfect; each cell with its C as the CLI prints it and a link to the two runs compared, the
    reference first (the code's run in the bands around the reference's). ``run_ids`` is
    RunQuerySet.matrix_runs of the same targets."""
    blocks = []
    for (testcase, run_name), present in matrix.runs.items():
        codes = [n for n in matrix.targets if n in present]
        ids = {}
        for code in codes:
            content = present[code].split(" ", 1)[-1]
            ids[code] = next((pk for (t, path, name, full), pk in run_ids.items()
                              if (t, path, name) == (code, testcase, run_name) and full[:8] == content), None)
        for quantity in QUANTITIES:
            cells = {(a, b): matrix.cell(testcase, run_name, quantity, a, b) for a in codes for b in codes if a != b}
            if not any(cells.values()) or (quantity == "atoms" and all(
                    c is None or c.level == "perfect" for c in cells.values())):
                continue
            rows = []
            for code in codes:
                row = []
                for reference in codes:
                    cell = cells.get((code, reference))
                    if code == reference or cell is None:
                        row.append({"diagonal": code == reference})
                        continue
                    url = None
                    if ids.get(code) and ids.get(reference):
                        url = reverse("compare") + "?" + urlencode({"run": f"{ids[reference]},{ids[code]}"})
                    row.append({"cell": cell, "text": _c(cell.value), "short": _short(cell.level), "url": url})
                rows.append({"code": code, "cells": row, "run_id": ids.get(code)})
            blocks.append({"testcase": testcase, "run": run_name, "quantity": quantity, "codes": codes,
                           "rows": rows, "provenance": present})
    return blocks
