"""``harness compare A B [-k PATTERN] [--json | --markdown] [--no-run] [--repeat N] [--profile]``: two revisions or two targets.

``A`` and ``B`` are ``TARGET`` or ``TARGET@REV`` (``dem@v1.2 dem@HEAD``, ``dem-reference dem``). Runs that
are missing are run first (``--no-run``: compare only what the store holds). See ``harness.analysis.compare``.
"""
import json
import sys

from harness.adapters.base import UserError
from harness.store import setup_store

NAME = "compare"
HELP = "compare two revisions of a target (or two targets): consistency, new failures, stepping-time ratio"


def configure(parser):
    parser.add_argument("a", metavar="A", help="baseline: TARGET or TARGET@REV")
    parser.add_argument("b", metavar="B", help="compared: TARGET or TARGET@REV")
    parser.add_argument("-k", dest="pattern", metavar="PATTERN", help="only runs whose 'testcase/run' match")
    parser.add_argument("-j", dest="jobs", type=int, default=1, metavar="N", help="runs in parallel (default 1)")
    parser.add_argument("--repeat", type=int, default=1, metavar="N",
                        help="run each engine N times (harness run --repeat): a stepping-time ratio counts as a "
                             "speed change only beyond the spread of the N times")
    parser.add_argument("--no-run", action="store_true", help="compare the runs in the store without running")
    parser.add_argument("--profile", action="store_true",
                        help="profile the runs (harness run --profile) and print, per run, the breakdown "
                             "sections and the functions whose share grew most from A to B")
    output = parser.add_mutually_exclusive_group()
    output.add_argument("--json", action="store_true", help="print the comparison as JSON")
    output.add_argument("--markdown", action="store_true", help="print a Markdown table (merge-request comment)")


def side(argument: str, folder):
    """One target definition for ``TARGET`` or ``TARGET@REV`` (a range is refused)."""
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.config.revisions import expand, split

    if ".." in (split(argument)[1] or ""):
        raise UserError(f"{argument!r}: compare takes one revision per side, not a range")
    return expand([argument], folder)[0][0]


def run(args) -> int:
    if args.jobs < 1 or args.repeat < 1:
        raise UserError("-j and --repeat must be at least 1")
    setup_store()
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.analysis.compare import compare_builds, markdown, rows, summary
    from harness.execution.builds import record_current_build
    from harness.execution.scheduler import RunOptions, format_table, run_targets
    from harness.report.textout import wrap
    from harness.store.runrecord import finite

    target_a, target_b = side(args.a, args.targets_dir), side(args.b, args.targets_dir)
    if not args.no_run:
        options = RunOptions(machine=args.machine, pattern=args.pattern, jobs=args.jobs, profile=args.profile,
                             repeat=args.repeat)
        report = run_targets([target_a, target_b], options)  # progress on stderr: stdout stays the report
        for problem in report.problems:
            print(f"harness: {problem}", file=sys.stderr)
    builds = []
    for argument, target in ((args.a, target_a), (args.b, target_b)):
        build = record_current_build(target, args.machine)
        if build is None:
            raise UserError(f"{argument}: no build of {target.revision[:12]} on machine {args.machine!r} "
                            f"(run 'harness run {argument}')")
        builds.append(build)
    comparison = compare_builds(builds[0], builds[1], args.machine, args.a, args.b, args.pattern)
    if not comparison.pairs:
        print(f"harness: no runs of {args.a} and {args.b} to compare" + (f" matching {args.pattern!r}"
              if args.pattern else ""), file=sys.stderr)
        return 5
    if args.json:
        data = comparison.as_dict()
        if args.profile:
            # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
            from harness.analysis.slowdown import explain

            data["profiles"] = [e.as_dict() for e in explain(comparison)]
        print(json.dumps(finite(data), indent=1, allow_nan=False, default=str))
    elif args.markdown:
        print(markdown(comparison), end="")
    else:
        print(format_table(rows(comparison)))
        print(wrap(summary(comparison), ""))
        if args.profile:
            print_profiles(comparison)
    return 1 if comparison.failed else 0


def print_profiles(comparison) -> None:
    """Per pair of runs (the most slowed-down first) the breakdown diff and the functions whose share of the
    profile grew most from A to B (``harness.analysis.slowdown``); a run without a profile is said to have none."""
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.analysis.slowdown import explain

    for explanation in explain(comparison):
        print()
        print("\n".join(explanation.lines()))
        if explanation.functions is None:
            print(" profile: none recorded for both runs (harness run --profile, or \"profile\": true)")
