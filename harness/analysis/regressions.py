"""Where the history of a test case changed: speed and physics over the successive builds of a target.

The history of a run configuration is its runs on one machine by the builds of one target (same test case
content), ordered by commit date. Two detectors mark the builds where something changed:

* **stepping time** (the engine's own loop time, no start-up or JIT): a build is marked when its time lies
  outside ``mean +/- k sd`` of the previous ``window`` builds (as CDash flags test times) *and* differs from
  that mean by at least ``min_change`` (relative), so that the noise of a quiet history (sd near 0) or of a
  busy machine does not raise alarms. ``k`` = 3, ``window`` = 5, ``min_change`` = 0.1 by default.
* **a quantity**: each build's run is compared with the previous build's run by ``harness.analysis.compare``; a build
  whose run is inconsistent with its predecessor (thesis eqs. 4.2-4.4) is marked with the quantities that
  left the band, their C and first bad step; a build where the run newly fails is marked too.
"""
from __future__ import annotations

import statistics
from dataclasses import dataclass, field

from harness.analysis.compare import attach_series, compare_pair, run_rows, scored, stepping_spread
from harness.config.testcases import matches
from harness.store.rules import SUCCESS_STATES, effective_state, speed_kind


@dataclass
class Change:
    commit: str
    previous_commit: str
    kind: str            # "slower", "faster", "quantity", "failure"
    detail: str
    run_id: int


@dataclass
class History:
    target: str
    testcase: str
    run: str
    points: list = field(default_factory=list)   # [(commit, committed_at, stepping_time, wall_time, C, state)]
    changes: list[Change] = field(default_factory=list)


def speed_changes(times: list[float | None], k: float = 3.0, window: int = 5, min_change: float = 0.1,
                  spreads: list[float] | None = None) -> list[tuple[int, float]]:
    """Indices whose stepping time leaves mean +/- k sd of the previous ``window`` values by at least
    ``min_change`` (relative) and by more than the measured spread (``relative_spread`` of that build's run
    and of the runs before it: a change inside the noise of repeated runs is no change), with the ratio to
    that mean."""
    out = []
    spreads = spreads or [0.0] * len(times)
    for i, value in enumerate(times):
        window_at = range(max(0, i - window), i)
        before = [times[j] for j in window_at if times[j]]
        if not value or len(before) < 2:
            continue
        mean = statistics.fmean(before)
        sd = statistics.stdev(before)
        ratio = value / mean
        noise = max([spreads[i]] + [spreads[j] for j in window_at])
        if abs(value - mean) > k * sd and speed_kind(ratio, noise, min_change) != "same":
            out.append((i, ratio))
    return out


def comparable(found: list[History]) -> int:
    """How many of the histories have runs of at least two builds: only those can show a change."""
    return sum(len({p[0] for p in h.points}) >= 2 for h in found)


def histories(machine: str, target: str | None = None, pattern: str | None = None, k: float = 3.0,
              window: int = 5, min_change: float = 0.1) -> list[History]:
    """The history of every run configuration (of ``target``, matching ``pattern``) with its changes."""
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Run

    runs = (Run.objects.filter(machine__name=machine, replaced=False).exclude(build__committed_at=None)
            .order_by("target__name", "testcase__path", "name", "testcase_hash", "build__committed_at", "build_id"))
    if target:
        runs = runs.filter(target__name=target)
    grouped: dict = {}
    # plain rows of what a history reads (effective_state, compare_pair, the spread of repeats): with 10,000
    # runs, model objects would be most of the time
    for run in run_rows(runs, "target__name", "build__commit", "build__committed_at"):
        if matches(pattern, run.testcase.path, run.name):
            grouped.setdefault((run.target__name, run.testcase.path, run.name, run.testcase_hash), []).append(run)
    # the series of the runs a history scores against the build before, read together
    attach_series(list({id(r): r for series in grouped.values() for previous, run in zip(series, series[1:])
                        if scored(previous, run) for r in (previous, run)}.values()))
    out = []
    for (target_name, testcase, name, _content), series in grouped.items():
        history = History(target_name, testcase, name)
        for run in series:
            history.points.append((run.build.commit, run.build.committed_at, run.stepping_time, run.wall_time,
                                   run.consistency_min, effective_state(run)))
        spreads = [stepping_spread(run) for run in series]
        for i, ratio in speed_changes([p[2] for p in history.points], k, window, min_change, spreads):
            history.changes.append(Change(series[i].build.commit, series[i - 1].build.commit,
                                          "slower" if ratio > 1 else "faster",
                                          f"stepping time {ratio:.2f}x the mean of the previous builds",
                                          series[i].pk))
        for previous, run in zip(series, series[1:]):
            ok_before = effective_state(previous) in SUCCESS_STATES
            ok_now = effective_state(run) in SUCCESS_STATES
            if ok_before and not ok_now:
                history.changes.append(Change(run.build.commit, previous.build.commit, "failure",
                                              f"{run.failure_reason}: {run.failure_message[:120]}", run.pk))
            elif ok_before and ok_now:
                pair = compare_pair(previous, run)
                if pair.outcome == "inconsistent":
                    detail = "; ".join(
                        f"{q.quantity} C = {q.value:.3g}" if q.value is not None else f"{q.quantity} {q.level}"
                        for q in pair.bad[:4])
                    history.changes.append(Change(run.build.commit, previous.build.commit, "quantity", detail,
                                                  run.pk))
        history.changes.sort(key=lambda c: next(i for i, p in enumerate(history.points) if p[0] == c.commit))
        out.append(history)
    return out


@dataclass
class BuildTime:
    target: str
    commit: str
    committed_at: object
    status: str          # complete, failed, building
    seconds: float | None
    error: str           # first error line of a failed build
    ccache_hits: int | None


def build_times(machine: str, target: str | None = None) -> list[BuildTime]:
    """Every build of ``target`` (all targets) on ``machine`` with its build time, ordered by commit date -
    failed builds too, which have no runs and so no history above. The time is the recipe's (export,
    configure, compile, link); a build through a warm ccache shows as a drop."""
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Build

    builds = (Build.objects.filter(machine__name=machine).exclude(target__definition__recipe="system")
              .select_related("target").order_by("target__name", "committed_at", "id"))
    if target:
        builds = builds.filter(target__name=target)
    out = []
    for build in builds:
        stats = (build.details or {}).get("ccache_stats") or {}
        hits = (stats.get("direct_cache_hit", 0) + stats.get("preprocessed_cache_hit", 0)) if stats else None
        out.append(BuildTime(build.target.name, build.commit, build.committed_at, build.status, build.duration,
                             (build.details or {}).get("error", "") if build.status == Build.Status.FAILED else "",
                             hits))
    return out
