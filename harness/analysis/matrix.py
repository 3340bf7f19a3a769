"""The cross-code consistency matrix: every code against every other, per scene and quantity.

``harness check`` scores a target against its one reference. Several codes that ran the same test case (same
path, run name and test case content hash, e.g. the scenes of ``testcases/crosscode/`` written for the
bundled engine, LIGGGHTS, LAMMPS and YADE) can be scored each against each: for the ordered pair (code A,
reference B) and each quantity q the consistency C_q(A | B) after thesis eqs. 4.2-4.4
(``harness.analysis.consistency.compare_runs``, with the run.config's ``consistency`` settings):

    eps = 0.1 (max_k x_B,k - min_k x_B,k) / 2,   C = 1 - max_k 0.1 |x_A,k - x_B,k| / eps

C is not symmetric (eps comes from the reference), so both orders are given. Runs are the successful ones of
each target's current build on the machine, which the caller passes (``harness.execution.builds``: the CLI records it
from the revision, the dashboard reads the recorded one).

The result is a list of ``Cell`` (test case, run, quantity, code, reference, C, level, first step outside
the band) that ``format_matrix`` prints as one square table per test case run and quantity, and
``write_csv`` / ``write_json`` store (``$HARNESS_HOME/matrix/``) for a dashboard page.
"""
from __future__ import annotations

import csv
import json
from dataclasses import asdict, dataclass, field
from pathlib import Path

from harness.analysis.check import series_of
from harness.analysis.consistency import compare_runs
from harness.config.testcases import matches
from harness.report.textout import format_table
from harness.store.rules import SUCCESS_STATES
from harness.store.runrecord import finite

#: thermo quantities shown in the matrix (others the codes print under different names are not comparable)
QUANTITIES = ("ke", "rke", "atoms")


@dataclass
class Cell:
    testcase: str
    run: str
    quantity: str
    code: str           # the target whose run is scored
    reference: str      # the target whose run gives eps and the reference trajectory
    value: float | None
    level: str
    first_bad_step: float | None = None
    message: str = ""


@dataclass
class Matrix:
    targets: list[str]
    cells: list[Cell] = field(default_factory=list)
    #: (test case, run) -> {target: "commit[:10] content[:8]"} of the runs compared
    runs: dict = field(default_factory=dict)
    problems: list[str] = field(default_factory=list)

    def cell(self, testcase: str, run: str, quantity: str, code: str, reference: str) -> Cell | None:
        return next((c for c in self.cells if (c.testcase, c.run, c.quantity, c.code, c.reference)
                     == (testcase, run, quantity, code, reference)), None)

    def lowest(self) -> dict[tuple[str, str], Cell]:
        """Per ordered pair (code, reference): the cell with the lowest C over all scenes and quantities."""
        worst: dict[tuple[str, str], Cell] = {}
        for c in self.cells:
            key = (c.code, c.reference)
            value = c.value if c.value is not None else float("-inf")
            if key not in worst or value < (worst[key].value if worst[key].value is not None else float("-inf")):
                worst[key] = c
        return worst


def _successful_runs(build, machine: str, pattern: str | None) -> dict:
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Run

    runs = (Run.objects.filter(build=build, machine__name=machine, replaced=False, state__in=SUCCESS_STATES)
            .select_related("testcase", "build").prefetch_related("series"))
    return {(r.testcase.path, r.name, r.testcase_hash): r for r in runs if matches(pattern, r.testcase.path, r.name)}


def build_matrix(builds: dict, machine: str, pattern: str | None = None,
                 quantities: tuple[str, ...] = QUANTITIES) -> Matrix:
    """C of every target's run against every other target's run of the same test case content; ``builds``
    maps each target name, in the matrix's order, to its current build on ``machine`` (or None)."""

    matrix = Matrix(list(builds))
    found = {}
    for name, build in builds.items():
        if build is None:
            matrix.problems.append(f"target {name!r} has no build of its revision on machine {machine!r} "
                                   f"(run 'harness run {name}')")
            continue
        found[name] = _successful_runs(build, machine, pattern)
    keys = sorted({key for runs in found.values() for key in runs})
    for testcase, run_name, content in keys:
        present = [name for name in matrix.targets if (testcase, run_name, content) in found.get(name, {})]
        if len(present) < 2:
            continue
        matrix.runs[(testcase, run_name)] = {
            name: f"{found[name][(testcase, run_name, content)].build.commit[:10]} {content[:8]}" for name in present}
        series = {name: series_of(found[name][(testcase, run_name, content)]) for name in present}
        config = (found[present[0]][(testcase, run_name, content)].config or {}).get("consistency")
        for code in present:
            for reference in present:
                if code == reference:
                    continue
                results = {r.quantity: r for r in compare_runs(series[code], series[reference], config)
                           if r.series_kind == "thermo"}
                for quantity in quantities:
                    r = results.get(quantity)
                    if r is None:
                        continue
                    matrix.cells.append(Cell(testcase, run_name, quantity, code, reference, r.value, r.level,
                                             r.first_bad_step, r.message))
    return matrix


def _c(value: float | None) -> str:
    """C for a table: 4 decimals in [-1, 1], else 3 significant digits (a C of -1e5 says "far off")."""
    if value is None:
        return "n/a"
    return f"{value:.4f}" if -1 <= value <= 1 else f"{value:.3g}"


def _short(level: str) -> str:
    return {"perfect": "P", "good": "G", "inconsistent": "I", "length_mismatch": "L", "missing": "M"}.get(level, "?")


def format_matrix(matrix: Matrix) -> str:
    """One square table per (test case, run, quantity): rows the scored code, columns the reference;
    ``C level`` (P perfect >= 0.95, G good >= 0.9, I inconsistent, L length mismatch, M missing)."""

    blocks = []
    names = matrix.targets
    for (testcase, run_name), present in matrix.runs.items():
        codes = [n for n in names if n in present]
        for quantity in QUANTITIES:
            cells = [matrix.cell(testcase, run_name, quantity, a, b) for a in codes for b in codes if a != b]
            if not any(cells) or (quantity == "atoms" and all(c is None or c.level == "perfect" for c in cells)):
                continue  # the particle count is shown only where it differs
            rows = [(f"{testcase}/{run_name} {quantity}", *codes)]
            for code in codes:
                row = [code]
                for reference in codes:
                    cell = matrix.cell(testcase, run_name, quantity, code, reference)
                    if code == reference:
                        row.append("-")
                    elif cell is None:
                        row.append("")
                    else:
                        value = _c(cell.value)
                        row.append(f"{value} {_short(cell.level)}")
                rows.append(tuple(row))
            blocks.append(format_table(rows))
    return "\n\n".join(blocks)


def write_csv(matrix: Matrix, path: Path) -> None:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(["testcase", "run", "quantity", "code", "reference", "C", "level", "first_bad_step",
                         "message"])
        for c in matrix.cells:
            writer.writerow([c.testcase, c.run, c.quantity, c.code, c.reference,
                             "" if c.value is None else repr(c.value), c.level,
                             "" if c.first_bad_step is None else c.first_bad_step, c.message])


def to_json(matrix: Matrix) -> dict:

    return finite({"targets": matrix.targets, "problems": matrix.problems,
                   "runs": [{"testcase": t, "run": r, "targets": present}
                            for (t, r), present in matrix.runs.items()],
                   "cells": [asdict(c) for c in matrix.cells]})


def write_json(matrix: Matrix, path: Path) -> None:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(to_json(matrix), indent=1, allow_nan=False), encoding="utf-8")
