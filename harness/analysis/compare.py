"""Two builds side by side (``harness compare A B``): two revisions of one target, or two targets.

Runs of A and B are paired by test case, run name and test case content (runs of other content are not
comparable and are listed as such). For each pair, B is scored against A with the consistency score of
``harness.analysis.consistency`` (A is the reference: C per quantity, first step out of band) plus the largest
relative deviation ``max_k |b_k - a_k| / max_k |a_k|`` on the common steps, and the stepping-time ratio
B/A (the engines' own loop time; no start-up, no JIT compilation) with the measured spread of repeated runs
(``harness run --repeat``): a ratio is a speed change only beyond that spread
(``harness.store.rules.speed_kind``, the rule of the regressions and the overview too). Outcomes:

``new_failure``  A succeeded, B failed;          ``fixed``          A failed, B succeeded;
``still_failing`` both failed;                   ``inconsistent``   both succeeded, some quantity of B is
                                                                    outside A's band;
``consistent``   both succeeded, every quantity within the band;
``only_a`` / ``only_b``: a run of one side without a partner of the same content.

The comparison fails (exit code 1 of ``harness compare``) on any new failure or inconsistency.
"""
from __future__ import annotations

import math
import statistics
from dataclasses import dataclass, field

import numpy as np

from harness.analysis.consistency import compare_runs, run_level
from harness.config.testcases import matches
from harness.store.rules import SUCCESS_STATES, effective_state, relative_spread, speed_kind

FAILING_OUTCOMES = ("new_failure", "inconsistent")


@dataclass
class QuantityDelta:
    """One quantity of B against A: C (thesis eq. 4.4), level, first step out of band, largest relative
    deviation (dimensionless, None for text files)."""

    quantity: str
    value: float | None
    level: str
    first_bad_step: float | None
    max_relative_deviation: float | None


@dataclass
class PairComparison:
    testcase: str
    run: str
    outcome: str
    a: object = None
    b: object = None
    quantities: list[QuantityDelta] = field(default_factory=list)
    time_ratio: float | None = None     # stepping time B / A
    noise: float = 0.0                  # the larger relative spread of A's and B's repeated stepping times

    @property
    def speed(self) -> str:
        """"slower", "faster" or "same": the stepping-time ratio beyond 10 % and beyond the spread."""
        return speed_kind(self.time_ratio, self.noise)

    @property
    def lowest_c(self) -> float | None:
        values = [q.value for q in self.quantities if q.value is not None]
        return min(values) if values else None

    @property
    def bad(self) -> list[QuantityDelta]:
        return [q for q in self.quantities if q.level not in ("perfect", "good")]

    def as_dict(self) -> dict:
        return {"testcase": self.testcase, "run": self.run, "outcome": self.outcome,
                "a": _run_summary(self.a), "b": _run_summary(self.b), "lowest_c": self.lowest_c,
                "time_ratio": self.time_ratio, "noise": self.noise, "speed": self.speed,
                "quantities": [q.__dict__ for q in self.quantities]}


@dataclass
class Comparison:
    label_a: str
    label_b: str
    commit_a: str
    commit_b: str
    pairs: list[PairComparison] = field(default_factory=list)

    def outcomes(self, *names: str) -> list[PairComparison]:
        return [p for p in self.pairs if p.outcome in names]

    @property
    def failed(self) -> bool:
        return bool(self.outcomes(*FAILING_OUTCOMES))

    @property
    def time_ratio(self) -> float | None:
        """Geometric mean of the per-run stepping-time ratios B/A (None without any)."""
        ratios = [p.time_ratio for p in self.pairs if p.time_ratio]
        return math.exp(sum(math.log(r) for r in ratios) / len(ratios)) if ratios else None

    @property
    def noise(self) -> float:
        """The median over the pairs with a stepping-time ratio of their measured spread (relative; 0 without
        ``--repeat``): the noise the geometric mean must exceed, as the overview's change against the build
        before (``harness.store.queries.stepping_changes``)."""
        spreads = [p.noise for p in self.pairs if p.time_ratio]
        return statistics.median(spreads) if spreads else 0.0

    @property
    def speed(self) -> str:
        """"slower", "faster" or "same" for the geometric mean (``harness.store.rules.speed_kind``)."""
        return speed_kind(self.time_ratio, self.noise)

    def counts(self) -> dict:
        out = dict.fromkeys(("consistent", "inconsistent", "new_failure", "fixed", "still_failing", "only_a",
                             "only_b"), 0)
        for pair in self.pairs:
            out[pair.outcome] += 1
        return out

    def as_dict(self) -> dict:
        return {"a": {"label": self.label_a, "commit": self.commit_a},
                "b": {"label": self.label_b, "commit": self.commit_b},
                "counts": self.counts(), "time_ratio": self.time_ratio, "noise": self.noise,
                "speed": self.speed, "failed": self.failed,
                "pairs": [p.as_dict() for p in self.pairs]}


def _run_summary(run) -> dict | None:
    if run is None:
        return None
    return {"id": run.pk, "state": effective_state(run), "failure_reason": run.failure_reason,
            "failure_message": run.failure_message[:300], "testcase_hash": run.testcase_hash,
            "stepping_time": run.stepping_time, "wall_time": run.wall_time}


def _series(run) -> list[dict]:
    if isinstance(run, RunRow):
        if run.series is None:
            attach_series([run])
        return run.series
    return [{"kind": s.kind, "name": s.name, "x_column": s.x_column, "columns": s.columns}
            for s in run.series.all()]


class RunRow:
    """A run as a comparison or a history reads it, from a plain row of the store (``ROW_FIELDS``): with
    10,000 runs, building Django model objects is most of a page's time. ``testcase.path`` and ``build``'s
    ``commit`` / ``committed_at`` are there as on a model; ``series`` and ``config`` are filled by
    ``attach_series`` for the runs that are scored; any other field (breakdown, folder, ...) is read from the
    store when first asked (``model``)."""

    def __init__(self, row: dict):
        self.__dict__ = fields = row  # the row is this object's fields: nothing copied
        fields["pk"] = row["id"]
        fields["testcase"] = _Named(path=fields.pop("testcase__path"))
        if "build__commit" in row:
            fields["build"] = _Named(commit=fields.pop("build__commit"),
                                     committed_at=fields.pop("build__committed_at", None))
        fields["series"] = None

    def __getattr__(self, name):  # called only for the fields the row does not hold
        if name.startswith("_"):
            raise AttributeError(name)
        if name == "model":
            # the store's models (Django) load once Django is set up (harness.store)
            from harness.store.models import Run

            self.model = Run.objects.get(pk=self.id)
            return self.model
        return getattr(self.model, name)


class _Named:
    def __init__(self, **fields):
        self.__dict__.update(fields)


#: the columns a comparison or a history reads of every run
ROW_FIELDS = ("id", "testcase__path", "name", "testcase_hash", "state", "replaced", "failure_reason",
              "failure_message", "finished", "consistency", "consistency_min", "stepping_time", "wall_time",
              "timing__stepping_repeats", "target_id", "build_id")


def run_rows(runs, *extra: str) -> list[RunRow]:
    """The runs of a Run QuerySet as RunRow objects (``extra``: more columns, e.g. build__commit)."""
    return [RunRow(row) for row in runs.values(*ROW_FIELDS, *extra)]


def stepping_spread(run) -> float:
    """The relative spread of a run's repeated stepping times (``harness.store.rules.relative_spread``), from a
    RunRow's column or a model's ``timing``."""
    if isinstance(run, RunRow):
        return relative_spread({"stepping_repeats": run.timing__stepping_repeats})
    return relative_spread(run.timing)


def attach_series(rows: list[RunRow], chunk: int = 500) -> None:
    """Read the data series and the run.config of ``rows`` in a few queries (``chunk`` runs each)."""
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Run, Series

    by_id = {row.pk: row for row in rows}
    for row in rows:
        row.series = []
    ids = list(by_id)
    for start in range(0, len(ids), chunk):
        part = ids[start:start + chunk]
        for run_id, config in Run.objects.filter(pk__in=part).values_list("id", "config"):
            by_id[run_id].config = config
        for s in (Series.objects.filter(run_id__in=part).order_by("pk")
                  .values("run_id", "kind", "name", "x_column", "columns")):
            by_id[s.pop("run_id")].series.append(s)


def max_relative_deviation(a_series: list[dict], b_series: list[dict], kind: str, name: str,
                           quantity: str) -> float | None:
    """``max |b - a| / max |a|`` over the common abscissa values of one quantity (None if not comparable)."""
    a = next((s for s in a_series if (s["kind"], s["name"]) == (kind, name)), None)
    b = next((s for s in b_series if (s["kind"], s["name"]) == (kind, name)), None)
    if a is None or b is None or kind == "textfile":
        return None
    try:
        xa = np.asarray(a["columns"][a["x_column"]], dtype=float)
        xb = np.asarray(b["columns"][b["x_column"]], dtype=float)
        ya = np.asarray(a["columns"][quantity], dtype=float)
        yb = np.asarray(b["columns"][quantity], dtype=float)
    except (KeyError, TypeError, ValueError):
        return None
    _common, ia, ib = np.intersect1d(xa, xb, return_indices=True)
    if ia.size == 0:
        return None
    scale = np.nanmax(np.abs(ya)) if np.isfinite(ya).any() else 0.0
    deviation = np.abs(yb[ib] - ya[ia])
    if not np.isfinite(deviation).all():
        return math.inf
    largest = float(deviation.max())
    return largest / scale if scale > 0 else (0.0 if largest == 0 else math.inf)


def scored(a, b) -> bool:
    """Whether ``compare_pair`` scores the quantities of A and B (both ran and succeeded)."""
    return effective_state(a) in SUCCESS_STATES and effective_state(b) in SUCCESS_STATES


def compare_pair(a, b) -> PairComparison:
    """B against A, both runs of the same test case content."""
    pair = PairComparison(a.testcase.path, a.name, "", a, b)
    # a run that never finished (interrupted harness, still in flight) is no result to compare
    if effective_state(a) == "not_executed" or effective_state(b) == "not_executed":
        pair.outcome = "only_b" if effective_state(a) == "not_executed" else "only_a"
        return pair
    ok_a, ok_b = effective_state(a) in SUCCESS_STATES, effective_state(b) in SUCCESS_STATES
    if a.stepping_time and b.stepping_time:
        pair.time_ratio = b.stepping_time / a.stepping_time
        pair.noise = max(stepping_spread(a), stepping_spread(b))
    if not ok_a or not ok_b:
        pair.outcome = ("still_failing" if not ok_a and not ok_b else "new_failure" if ok_a else "fixed")
        return pair
    a_series, b_series = _series(a), _series(b)
    results = compare_runs(b_series, a_series, (b.config or {}).get("consistency"))
    for r in results:
        pair.quantities.append(QuantityDelta(
            f"{r.series_name}:{r.quantity}" if r.series_kind != "thermo" else r.quantity, r.value, r.level,
            r.first_bad_step, max_relative_deviation(a_series, b_series, r.series_kind, r.series_name, r.quantity)))
    level, _lowest = run_level(results)
    pair.outcome = "inconsistent" if level == "inconsistent" else "consistent"
    return pair


def compare_builds(build_a, build_b, machine: str, label_a: str, label_b: str, pattern: str | None = None
                   ) -> Comparison:
    """Pair and compare the runs of two builds on ``machine`` (``pattern``: ``-k`` selection)."""
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Run

    def runs_of(build):
        found = {}
        for run in run_rows(Run.objects.filter(build=build, machine__name=machine, replaced=False)
                            .order_by("testcase__path", "name")):
            if matches(pattern, run.testcase.path, run.name):
                found[(run.testcase.path, run.name, run.testcase_hash)] = run
        return found

    runs_a, runs_b = runs_of(build_a), runs_of(build_b)
    comparison = Comparison(label_a, label_b, build_a.commit, build_b.commit)
    keys = sorted(set(runs_a) | set(runs_b))
    # the series of the pairs that are scored, read together
    attach_series([run for key in keys if key in runs_a and key in runs_b and scored(runs_a[key], runs_b[key])
                   for run in (runs_a[key], runs_b[key])])
    for key in keys:
        a, b = runs_a.get(key), runs_b.get(key)
        if a is not None and b is not None:
            comparison.pairs.append(compare_pair(a, b))
        else:
            comparison.pairs.append(PairComparison(key[0], key[1], "only_a" if b is None else "only_b", a, b))
    return comparison


# ------------------------------------------------------------------------------------------------ reports

def _c(value) -> str:
    return "-" if value is None else f"{value:.4g}"


def _dev(value) -> str:
    return "-" if value is None else ("inf" if math.isinf(value) else f"{value:.3g}")


#: the columns of a comparison's table
HEADER = ("test case", "run", "outcome", "min C", "worst quantity", "max rel dev", "first bad step", "stepping B/A")
#: the order of a comparison's rows: the worst outcomes first
OUTCOME_ORDER = {"new_failure": 0, "inconsistent": 1, "fixed": 2, "still_failing": 3, "only_a": 4, "only_b": 5,
                 "consistent": 6}


def row_order(pair: PairComparison) -> tuple:
    """Sort key of a pair in ``rows``: outcome (``OUTCOME_ORDER``), test case, run."""
    return OUTCOME_ORDER[pair.outcome], pair.testcase, pair.run


def rows(comparison: Comparison) -> list[tuple]:
    """Table rows: one per pair, worst quantity first."""
    out = [HEADER]
    for pair in sorted(comparison.pairs, key=row_order):
        worst = min(pair.quantities, key=lambda q: (q.value is not None, q.value or 0.0), default=None)
        detail = ""
        if pair.outcome in ("new_failure", "still_failing", "fixed"):
            failed = pair.b if pair.outcome != "fixed" else pair.a
            detail = ": ".join(part for part in (failed.failure_reason, failed.failure_message[:60]) if part)
        out.append((pair.testcase, pair.run, pair.outcome, _c(pair.lowest_c),
                    worst.quantity if worst is not None and pair.bad else detail,
                    _dev(max((q.max_relative_deviation for q in pair.quantities
                              if q.max_relative_deviation is not None), default=None)),
                    f"{worst.first_bad_step:g}" if worst is not None and worst.first_bad_step is not None else "-",
                    ratio_text(pair.time_ratio, pair.noise)))
    return out


#: how a comparison's summary names ``harness.store.rules.speed_kind``
SPEED_WORDS = {"slower": "slower", "faster": "faster", "same": "no speed change"}


def ratio_text(ratio: float | None, noise: float) -> str:
    """A stepping-time ratio B/A for a table cell, with the measured spread of repeated runs: ``1.312 ±4%``."""
    if not ratio:
        return "-"
    return f"{ratio:.3f}" + (f" ±{noise * 100:.0f}%" if noise else "")


def speed_summary(comparison: Comparison) -> str:
    """The geometric mean of the stepping-time ratios, its spread and whether it is a speed change."""
    ratio = comparison.time_ratio
    if not ratio:
        return ""
    spread = f", spread of repeated runs {comparison.noise * 100:.0f} %" if comparison.noise else ""
    return f"stepping time B/A {ratio:.3f} (geometric mean{spread}: {SPEED_WORDS[comparison.speed]})"


def summary(comparison: Comparison) -> str:
    counts = comparison.counts()
    ratio = comparison.time_ratio
    return (f"{comparison.label_b} ({comparison.commit_b[:10]}) against {comparison.label_a} "
            f"({comparison.commit_a[:10]}): {counts['consistent']} consistent, {counts['inconsistent']} "
            f"inconsistent, {counts['new_failure']} new failures, {counts['fixed']} fixed, "
            f"{counts['still_failing']} still failing"
            + (f", {counts['only_a'] + counts['only_b']} without a partner" if counts['only_a'] + counts['only_b']
               else "")
            + (f"; {speed_summary(comparison)}" if ratio else ""))


def markdown(comparison: Comparison) -> str:
    """The comparison as a merge-request comment."""
    verdict = "**failed**" if comparison.failed else "passed"
    lines = [f"### {comparison.label_b} against {comparison.label_a}: {verdict}", "", summary(comparison), ""]
    table = rows(comparison)
    lines.append("| " + " | ".join(table[0]) + " |")
    lines.append("|" + "---|" * len(table[0]))
    for row in table[1:]:
        lines.append("| " + " | ".join(str(cell).replace("|", "\\|") for cell in row) + " |")
    return "\n".join(lines) + "\n"
