"""Finding the commit that broke a target (``harness bisect TARGET GOOD BAD``), in about log2(n) builds.

GOOD is run once as the baseline. Then, between GOOD and BAD (git's ``GOOD..BAD``: every commit reachable
from BAD and not from GOOD), a commit is *bad* when its runs, compared with GOOD's by ``harness.analysis.compare``,
have a new failure or an inconsistency - or, with ``slower``, when the geometric mean of its stepping-time
ratios to GOOD reaches that factor and exceeds the measured spread of repeated runs (``harness run --repeat``;
``harness.store.rules.speed_kind``, the rule of the regressions and the overview). The search keeps the
invariant "last known good < first bad" and halves the interval each step; a commit that cannot be built is
skipped (the nearest buildable commit is tried), as ``git bisect skip`` does.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from harness.adapters.base import UserError
from harness.analysis.compare import Comparison, compare_builds
from harness.config import gitrepo
from harness.config.revisions import at_revision
from harness.execution.builds import record_current_build
from harness.execution.scheduler import RunOptions, run_targets
from harness.store.rules import speed_kind


@dataclass
class Step:
    commit: str
    verdict: str          # "good", "bad", "skip"
    detail: str = ""


@dataclass
class BisectResult:
    first_bad: str | None
    comparison: Comparison | None
    steps: list[Step] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    candidates: list[str] = field(default_factory=list)   # when skips leave several possible commits


def judge(comparison: Comparison, slower: float | None) -> tuple[str, str]:
    """("bad" | "good", why) for a commit's comparison with GOOD."""
    if comparison.failed:
        broken = comparison.outcomes("new_failure", "inconsistent")
        first = broken[0]
        what = (f"{first.testcase}/{first.run} {first.outcome}"
                + (f" (lowest C {first.lowest_c:.4g})" if first.lowest_c is not None else ""))
        return "bad", f"{len(broken)} run(s) broke, e.g. {what}"
    ratio, noise = comparison.time_ratio, comparison.noise
    spread = f", spread of repeated runs {noise * 100:.0f} %" if noise else ""
    # the rule of the regressions and the overview: a change counts only beyond the measured spread
    if slower and speed_kind(ratio, noise, slower - 1.0) == "slower":
        return "bad", f"stepping time {ratio:.3f}x GOOD's (limit {slower:g}{spread})"
    if slower and ratio and ratio >= slower:
        return "good", (f"consistent; stepping time {ratio:.3f}x GOOD's, within the spread of repeated runs "
                        f"{noise * 100:.0f} %")
    return "good", (f"consistent; stepping time {ratio:.3f}x GOOD's{spread}" if ratio else "consistent")


def bisect(target, good: str, bad: str, machine: str, pattern: str | None = None, slower: float | None = None,
           jobs: int = 1, say=print, profile: bool = False, repeat: int = 1) -> BisectResult:
    repo = gitrepo.open_repository(target.repository)
    good_commit, bad_commit = gitrepo.resolve(repo, good).hexsha, gitrepo.resolve(repo, bad).hexsha
    commits = repo.git.rev_list("--reverse", f"{good_commit}..{bad_commit}").split()
    if not commits:
        raise UserError(f"bisect: no commits between {good} and {bad} ({bad} is not a descendant of {good})")
    options = RunOptions(machine=machine, pattern=pattern, jobs=jobs, profile=profile, repeat=repeat)
    say(f"bisect {target.name}: {len(commits)} commits after {good_commit[:10]} up to {bad_commit[:10]}, "
        f"about {max(1, (len(commits)).bit_length())} builds")
    good_build = _run(target, good_commit, options, say)
    if good_build is None:
        raise UserError(f"bisect: GOOD {good} ({good_commit[:10]}) cannot be built")
    result = BisectResult(None, None)
    comparisons: dict[str, Comparison] = {}

    def test(index: int) -> str:
        commit = commits[index]
        build = _run(target, commit, options, say)
        if build is None:
            result.steps.append(Step(commit, "skip", f"build failed: {_build_error(target, commit, machine)}"))
            result.skipped.append(commit)
            say(f"  {commit[:10]} skip ({result.steps[-1].detail})")
            return "skip"
        comparison = compare_builds(good_build, build, machine, f"{target.name}@{good_commit[:10]}",
                                    f"{target.name}@{commit[:10]}", pattern)
        if not comparison.pairs:
            raise UserError("bisect: no runs to compare" + (f" matching {pattern!r}" if pattern else ""))
        verdict, why = judge(comparison, slower)
        comparisons[commit] = comparison
        result.steps.append(Step(commit, verdict, why))
        say(f"  {commit[:10]} {verdict}: {why}")
        return verdict

    if test(len(commits) - 1) != "bad":
        raise UserError(f"bisect: BAD {bad} ({bad_commit[:10]}) is not bad against GOOD {good}: "
                        f"{result.steps[-1].detail}")
    lo, hi = -1, len(commits) - 1          # commits[lo] good (or GOOD itself), commits[hi] bad
    while hi - lo > 1:
        untested = [i for i in range(lo + 1, hi) if commits[i] not in result.skipped]
        if not untested:                   # only unbuildable commits left between: any may be the first bad
            result.candidates = commits[lo + 1:hi + 1]
            break
        mid = untested[len(untested) // 2]
        verdict = test(mid)
        if verdict == "bad":
            hi = mid
        elif verdict == "good":
            lo = mid
    result.first_bad = commits[hi] if not result.candidates else None
    result.comparison = comparisons.get(commits[hi])
    return result


def _run(target, commit: str, options: RunOptions, say):
    """Build and run ``target`` at ``commit``; its build, or None when it cannot be built (its failed build
    is stored, ``harness.execution.builds``: a second bisect over the same commits does not build it again)."""
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Build

    pinned = at_revision(target, commit)
    report = run_targets([pinned], options, out=_Lines(say))
    failed = Build.objects.filter(target__name=target.name, machine__name=options.machine, commit=commit,
                                  definition_hash=pinned.definition_hash, status=Build.Status.FAILED).first()
    if failed is not None or any("build of target" in p for p in report.problems):
        return None
    return record_current_build(pinned, options.machine)


def _build_error(target, commit: str, machine: str) -> str:
    """The first error line of the stored failed build of ``target`` at ``commit`` (or a placeholder)."""
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Build

    build = (Build.objects.filter(target__name=target.name, machine__name=machine, commit=commit,
                                  status=Build.Status.FAILED).order_by("-finished").first())
    return ((build.details or {}).get("error") or "see its log") if build else "see its log"


class _Lines:
    """Progress of the runs at one commit, condensed: only problems are passed on."""

    def __init__(self, say):
        self.say = say

    def write(self, text):
        for line in text.splitlines():
            if line.startswith("harness:"):
                self.say("    " + line[:300])

    def flush(self):
        pass
