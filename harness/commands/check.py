"""``harness check [TARGET ...] [--junit FILE]``: version consistency against the reference target."""
import sys

NAME = "check"
HELP = "check version consistency of runs against the reference target; write JUnit XML"


def configure(parser):
    parser.add_argument("targets", nargs="*", metavar="TARGET", help="target names, TARGET@REV (any git revision) or TARGET@A..B (default: all)")
    parser.add_argument("--junit", metavar="FILE", help="write JUnit XML (Jenkins) to FILE")


def run(args) -> int:
    from harness.check import check_targets, write_junit
    from harness.runner import format_table
    from harness.store import setup_store
    from harness.revisions import expand

    setup_store()
    targets, problems = expand(args.targets, args.targets_dir)
    report = check_targets(targets, args.machine)
    report.problems[:0] = problems
    for problem in report.problems:
        print(f"harness: {problem}", file=sys.stderr)
    for line in report.stale_references:
        print(f"harness: stale reference run: {line}", file=sys.stderr)
    rows = [("target", "commit", "test case", "run", "content", "reference", "result", "consistency", "min C",
             "detail")]
    for v in report.verdicts:
        run = v.run
        reference = run.reference_run
        rows.append((run.target.name, run.build.commit[:10], run.testcase.path, run.name, run.short_hash or "-",
                     f"{reference.target.name}@{reference.build.commit[:10]}" if reference is not None else "-",
                     v.status, run.consistency or "-",
                     f"{run.consistency_min:.4g}" if run.consistency_min is not None else "-",
                     (v.message or "; ".join(v.overridden))[:100]))
    if report.verdicts:
        print(format_table(rows))
    if args.junit:
        write_junit(report, args.junit)
        print(f"JUnit XML written to {args.junit}")
    counts = {status: sum(v.status == status for v in report.verdicts) for status in ("passed", "failed", "skipped")}
    print(f"{len(report.verdicts)} runs: {counts['passed']} passed, {counts['failed']} failed, "
          f"{counts['skipped']} skipped; {len(report.problems)} problems")
    return 1 if counts["failed"] or report.problems else 0
