"""``harness bisect TARGET GOOD BAD [-k PATTERN] [--slower FACTOR] [--repeat N] [--profile]``: the first commit that broke a target."""
import sys

from harness.adapters.base import UserError
from harness.store import setup_store

NAME = "bisect"
HELP = "find the first commit between GOOD and BAD whose runs fail, become inconsistent or slow down"


def configure(parser):
    parser.add_argument("target", metavar="TARGET", help="target name (its repository is searched)")
    parser.add_argument("good", metavar="GOOD", help="a revision known to be good (tag, branch, sha, HEAD~n)")
    parser.add_argument("bad", metavar="BAD", help="a later revision known to be bad")
    parser.add_argument("-k", dest="pattern", metavar="PATTERN", help="only runs whose 'testcase/run' match")
    parser.add_argument("-j", dest="jobs", type=int, default=1, metavar="N", help="runs in parallel (default 1)")
    parser.add_argument("--repeat", type=int, default=1, metavar="N",
                        help="run each engine N times (harness run --repeat): a stepping-time ratio counts as a "
                             "speed change only beyond the spread of the N times")
    parser.add_argument("--slower", type=float, metavar="FACTOR",
                        help="bad = stepping time grew by FACTOR (e.g. 1.2) against GOOD, besides failures")
    parser.add_argument("--profile", action="store_true",
                        help="profile every run (harness run --profile), so that a slower commit comes with the "
                             "functions whose share grew")


def run(args) -> int:
    if args.slower is not None and not args.slower > 1.0:
        raise UserError("--slower must be a factor above 1 (e.g. 1.2)")
    if args.jobs < 1 or args.repeat < 1:
        raise UserError("-j and --repeat must be at least 1")
    setup_store()
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.analysis.bisect import bisect
    from harness.analysis.compare import rows
    from harness.config import gitrepo
    from harness.config.targets import select_targets
    from harness.execution.scheduler import format_table
    from harness.report.links import commit_page

    (target,), _problems = select_targets([args.target], args.targets_dir)
    result = bisect(target, args.good, args.bad, args.machine, args.pattern, args.slower, args.jobs,
                    say=lambda text: print(text, file=sys.stderr, flush=True), profile=args.profile,
                    repeat=args.repeat)
    if result.first_bad is None:
        print(f"the first bad commit is one of {len(result.candidates)} that cannot be built: "
              + " ".join(c[:10] for c in result.candidates))
        return 1
    commit = gitrepo.resolve(gitrepo.open_repository(target.repository), result.first_bad)
    print(f"first bad commit: {commit.hexsha}\n"
          f"author: {commit.author.name} <{commit.author.email}>\n"
          f"date:   {commit.committed_datetime.isoformat()}\n"
          f"        {commit.summary}\n"
          f"({len(result.steps)} commits tested" + (f", {len(result.skipped)} skipped" if result.skipped else "")
          + ")")
    page = commit_page(target.name, commit.hexsha, args.machine)
    if page:
        print(f"dashboard: {page}")
    comparison = result.comparison
    if comparison is not None:
        broken = [p for p in comparison.pairs if p.outcome in ("new_failure", "inconsistent")]
        if broken:
            print("\nwhat broke against GOOD:")
            for pair in broken:
                if pair.outcome == "new_failure":
                    print(f"  {pair.testcase}/{pair.run}: failed ({pair.b.failure_reason}: "
                          f"{pair.b.failure_message[:120]})")
                for q in pair.bad:
                    step = f", first bad step {q.first_bad_step:g}" if q.first_bad_step is not None else ""
                    c = f"C = {q.value:.4g}" if q.value is not None else q.level
                    print(f"  {pair.testcase}/{pair.run} {q.quantity}: {c}{step}")
        elif args.slower:
            spread = f", spread of repeated runs {comparison.noise * 100:.0f} %" if comparison.noise else ""
            print(f"\nstepping time against GOOD: {comparison.time_ratio:.3f}x (geometric mean{spread})")
            print(format_table(rows(comparison)))
            print_slowdown(comparison)
    return 0


def print_slowdown(comparison, runs: int = 3) -> None:
    """Why the first slow commit is slower than GOOD: per most slowed-down run its breakdown against GOOD's,
    and the profile diff where both were profiled (``harness.analysis.slowdown``)."""
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.analysis.slowdown import explain

    explanations = explain(comparison, limit=runs)
    if not explanations:
        return
    print("\nwhere the time went (B = the first slow commit, A = GOOD):")
    for explanation in explanations:
        print("\n".join(explanation.lines()))
