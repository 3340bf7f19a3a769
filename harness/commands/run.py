"""``harness run [TARGET ...] [-k PATTERN] [-j N] [--rerun-failed] [--working-tree] [--scheduler ADDRESS]``."""
import sys
from pathlib import Path

from harness.adapters.base import UserError
from harness.store import setup_store

NAME = "run"
HELP = "build targets if needed and run their test cases"


def add_selection(parser, what: str = "runs"):
    """The options that choose what to run, shared with ``harness sweep``."""
    parser.add_argument("targets", nargs="*", metavar="TARGET", help="target names, TARGET@REV (any git revision) or TARGET@A..B (default: all)")
    parser.add_argument("-k", dest="pattern", metavar="PATTERN",
                        help=f"only {what} whose 'testcase/run' contains PATTERN (or matches it as a glob)")
    parser.add_argument("-j", dest="jobs", type=int, default=1, metavar="N", help="runs in parallel (default 1)")
    parser.add_argument("--working-tree", action="store_true",
                        help="take test cases from the working tree instead of testcases_revision")


def configure(parser):
    add_selection(parser)
    parser.add_argument("--testcases", metavar="FOLDER",
                        help="run the test cases of this folder (anywhere on disk) instead of the targets' own")
    parser.add_argument("--repeat", type=int, default=1, metavar="N",
                        help="run each engine N times and keep the N stepping times (their spread decides which "
                             "speed changes are marked); runs stored with fewer times run again")
    parser.add_argument("--steps", type=int, metavar="N",
                        help="with TARGET@A..B: N commits spread evenly over the range (default: every commit)")
    parser.add_argument("--rerun-failed", action="store_true", help="run failed runs again")
    parser.add_argument("--all", dest="rerun_all", action="store_true",
                        help="run everything again, also runs that already succeeded with this build")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="submit runs to an existing Dask distributed scheduler (tcp://host:8786); "
                             "run folders must be on a file system the workers share")
    parser.add_argument("--force-build", action="store_true", help="rebuild the targets first")
    parser.add_argument("--no-reference", action="store_true",
                        help="do not also run the reference targets of the named targets")
    parser.add_argument("--profile", action="store_true",
                        help="record a sampling profile of every run (perf record -g for native codes, the phase "
                             "timers of the bundled engine): profile.folded in the run folder; runs recorded "
                             "without a profile run again")


def run(args) -> int:
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.config.revisions import expand
    from harness.execution.scheduler import RunOptions, run_targets, summary_table

    setup_store()
    targets, problems = expand(args.targets, args.targets_dir, args.steps)
    if args.targets and not args.no_reference:
        targets = with_references(targets)
    if args.testcases:
        # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
        from harness.config.targets import with_testcases

        if not Path(args.testcases).expanduser().is_dir():

            raise UserError(f"--testcases: {args.testcases}: no such folder")
        targets = [with_testcases(t, args.testcases) for t in targets]
    if args.jobs < 1 or args.repeat < 1:

        raise UserError("-j and --repeat must be at least 1")
    options = RunOptions(machine=args.machine, pattern=args.pattern, jobs=args.jobs,
                         rerun_failed=args.rerun_failed, rerun_all=args.rerun_all, working_tree=args.working_tree,
                         scheduler=args.scheduler, force_build=args.force_build, repeat=args.repeat,
                         profile=args.profile)
    report = run_targets(targets, options)
    report.problems[:0] = problems
    for problem in problems:
        print(f"harness: {problem}", file=sys.stderr)
    if report.records:
        print(summary_table(report.records))
    failed = len(report.failed)
    print(f"{len(report.records)} runs: {len(report.records) - failed} ok, {failed} failed, "
          f"{report.skipped} already done (use --all to run them again); {len(report.problems)} problems; "
          f"{report.elapsed:.1f} s")
    if failed or report.problems:
        return 1
    return 5 if not report.records and not report.skipped else 0  # the selection matched nothing (as pytest)


def with_references(targets):
    """The named targets and, after them, their reference targets (transitively), each once.

    A check needs the reference's runs; they are cached, so naming only the target under test is enough.
    """
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.config.targets import reference_of

    chosen = list(targets)
    names = {t.name for t in chosen}
    for target in chosen:  # grows while iterating: references of references
        reference = reference_of(target)
        if reference is not None and reference.name not in names:
            chosen.append(reference)
            names.add(reference.name)
    return chosen


def run_points(args, targets, problems, points: str, **options):
    """Run the study points of ``targets`` (runs named ``NAME@...``: ``points`` is the glob after the name,
    within ``-k``) unless ``--no-run``, then read them: (runs that failed, [(target, build, runs)]) of
    ``harness.execution.scheduler.run_and_read``. The selection's problems are printed first. ``harness
    scaling`` and ``harness sweep`` tabulate what it returns."""
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.execution.scheduler import RunOptions, run_and_read

    for problem in problems:
        print(f"harness: {problem}", file=sys.stderr)
    pattern = f"*{args.pattern}*{points}" if args.pattern else f"*{points}"
    run_options = RunOptions(machine=args.machine, pattern=pattern, working_tree=args.working_tree, **options)
    return run_and_read(targets, run_options, run=not args.no_run)
