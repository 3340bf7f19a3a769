"""``harness check [TARGET ...] [-k PATTERN] [-q] [--json] [--junit FILE]``: version consistency against the
reference target. Exit code 0 all passed, 1 a failure, inconsistency, stale run or problem, 5 nothing
selected."""
import json
import sys

NAME = "check"
HELP = "check version consistency of runs against the reference target; write JUnit XML"


def configure(parser):
    parser.add_argument("targets", nargs="*", metavar="TARGET",
                        help="target names, TARGET@REV (any git revision) or TARGET@A..B (default: all)")
    parser.add_argument("-k", dest="pattern", metavar="PATTERN", help="only runs whose 'testcase/run' match")
    parser.add_argument("-q", dest="quiet", action="store_true", help="list only the runs that did not pass")
    parser.add_argument("--json", action="store_true", help="print the verdicts as JSON")
    parser.add_argument("--junit", metavar="FILE", help="write JUnit XML (Jenkins) to FILE")
    add_allow_missing(parser)


def add_allow_missing(parser):
    parser.add_argument("--allow-missing", action="store_true",
                        help="runs of the current build that were not executed are skipped, not failures")


def verdict_dict(v) -> dict:
    run, reference = v.run, v.run.reference_run
    return {"target": run.target.name, "commit": run.build.commit, "testcase": run.testcase.path, "run": run.name,
            "testcase_hash": run.testcase_hash, "status": v.status, "kind": v.kind, "message": v.message,
            "consistency": run.consistency, "lowest_c": run.consistency_min, "overridden": v.overridden,
            "reference": None if reference is None else {"target": reference.target.name,
                                                         "commit": reference.build.commit}}


def run(args) -> int:
    from harness.check import check_targets, write_junit
    from harness.revisions import expand
    from harness.runner import format_table
    from harness.runrecord import finite
    from harness.store import setup_store

    setup_store()
    targets, problems = expand(args.targets, args.targets_dir)
    report = check_targets(targets, args.machine, pattern=args.pattern, allow_missing=args.allow_missing)
    report.problems[:0] = problems
    for problem in report.problems:
        print(f"harness: {problem}", file=sys.stderr)
    for line in report.stale_references:
        print(f"harness: stale reference run: {line}", file=sys.stderr)
    shown = [v for v in report.verdicts if not args.quiet or v.status != "passed"]
    if args.json:
        print(json.dumps(finite([verdict_dict(v) for v in shown]), indent=1, allow_nan=False))
    elif shown:
        rows = [("target", "commit", "test case", "run", "content", "reference", "result", "consistency", "min C",
                 "detail")]
        for v in shown:
            run, reference = v.run, v.run.reference_run
            rows.append((run.target.name, run.build.commit[:10], run.testcase.path, run.name, run.short_hash or "-",
                         f"{reference.target.name}@{reference.build.commit[:10]}" if reference is not None else "-",
                         v.status, run.consistency or "-",
                         f"{run.consistency_min:.4g}" if run.consistency_min is not None else "-",
                         (v.message or "; ".join(v.overridden))[:100]))
        print(format_table(rows))
    if args.junit:
        write_junit(report, args.junit)
        print(f"JUnit XML written to {args.junit}", file=sys.stderr if args.json else sys.stdout)
    counts = {status: sum(v.status == status for v in report.verdicts) for status in ("passed", "failed", "skipped")}
    print(f"{len(report.verdicts)} runs: {counts['passed']} passed, {counts['failed']} failed, "
          f"{counts['skipped']} skipped; {len(report.problems)} problems", file=sys.stderr if args.json else sys.stdout)
    if counts["failed"] or report.problems:
        return 1
    return 5 if not report.verdicts else 0
