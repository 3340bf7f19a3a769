"""``harness ci [TARGET ...] [--junit FILE] [-k PATTERN] [-j N]``: the whole CI job in one command.

Builds the targets (and their reference targets), runs what is not yet run for the test case content of
now, checks consistency against the references, writes JUnit XML, and exits with one code: 0 all passed,
1 something failed, is inconsistent or stale, or an input file is broken, 5 nothing was selected.
See docs/ci.md for Jenkins and GitLab/GitHub set-ups.
"""
import sys

from harness.store import setup_store

NAME = "ci"
HELP = "build, run, check and write JUnit XML in one command, with one exit code"


def configure(parser):
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.commands.check import add_allow_missing
    from harness.commands.run import add_selection

    add_selection(parser)
    add_allow_missing(parser)
    parser.add_argument("--junit", metavar="FILE", default="junit.xml", help="JUnit XML file (default junit.xml)")
    parser.add_argument("--rerun-failed", action="store_true", help="run failed runs again")


def run(args) -> int:
    setup_store()
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.analysis.check import check_targets, write_junit
    from harness.commands.run import with_references
    from harness.config.revisions import expand
    from harness.execution.scheduler import RunOptions, run_targets
    from harness.report.links import commit_page

    targets, problems = expand(args.targets, args.targets_dir)
    everything = with_references(targets) if args.targets else targets
    options = RunOptions(machine=args.machine, pattern=args.pattern, jobs=args.jobs,
                         rerun_failed=args.rerun_failed, working_tree=args.working_tree)
    ran = run_targets(everything, options)
    report = check_targets(targets, args.machine, pattern=args.pattern, allow_missing=args.allow_missing)
    report.problems[:0] = problems + ran.problems
    for problem in report.problems:
        print(f"harness: {problem}", file=sys.stderr)
    write_junit(report, args.junit)
    counts = {s: sum(v.status == s for v in report.verdicts) for s in ("passed", "failed", "skipped")}
    print(f"ci: {len(ran.records)} runs executed ({len(ran.failed)} failed), {ran.skipped} already done; "
          f"{len(report.verdicts)} checked: {counts['passed']} passed, {counts['failed']} failed, "
          f"{counts['skipped']} not run; {len(report.problems)} problems; JUnit XML: {args.junit}")
    builds = sorted({(v.run.target.name, v.run.build.commit) for v in report.verdicts})
    for target, commit in builds:
        page = commit_page(target, commit, args.machine)
        if page:
            print(f"dashboard: {target} at {commit[:10]}: {page}")
    if not report.verdicts and not report.problems:
        return 5
    return 1 if counts["failed"] or report.problems or ran.failed else 0
