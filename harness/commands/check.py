"""``harness check [TARGET ...] [-k PATTERN] [-q] [-v] [--json] [--junit FILE]``: version consistency against
the reference target. Exit code 0 all passed, 1 a failure, inconsistency, stale run or problem, 5 nothing
selected.

The table fits the CLI's width (``--wide``: whole), its detail column cut to fit; ``-v`` prints every message
whole below the table. A run a reviewer overruled reads ``overruled`` with the reviewer and the reason first.
"""
import json
import sys

from harness.report.glossary import level_word
from harness.store import setup_store

NAME = "check"
HELP = "check version consistency of runs against the reference target; write JUnit XML"


def configure(parser):
    parser.add_argument("targets", nargs="*", metavar="TARGET",
                        help="target names, TARGET@REV (any git revision) or TARGET@A..B (default: all)")
    parser.add_argument("-k", dest="pattern", metavar="PATTERN", help="only runs whose 'testcase/run' match")
    parser.add_argument("-q", dest="quiet", action="store_true", help="list only the runs that did not pass")
    parser.add_argument("-v", dest="verbose", action="store_true",
                        help="print every run's whole message below the table (the table cuts them to fit)")
    parser.add_argument("--json", action="store_true", help="print the verdicts as JSON")
    parser.add_argument("--testcases", metavar="FOLDER",
                        help="check the runs of the test cases of this folder (as 'harness run --testcases' ran "
                             "them) instead of the targets' own")
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


def result_and_detail(v) -> tuple[str, str]:
    """The result column and the detail of a verdict: an overruled run names its reviewer and reason
    before what was overruled."""
    if v.overridden:
        # harness.analysis.check.overruled words each override with its reviewer and reason first
        detail = "; ".join(v.overridden) + (f"; was: {v.message}" if v.message else "")
        return ("overruled" if v.status == "passed" else v.status), detail
    # the glossary's word (harness/report/glossary.py): a skipped run (outdated, or not executed with --allow-missing) is
    # "not run" (JUnit: skipped)
    return ("not run" if v.status == "skipped" else v.status), v.message


def run(args) -> int:
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.analysis.check import check_targets, write_junit
    from harness.config.revisions import expand
    from harness.config.targets import with_testcases
    from harness.execution.scheduler import format_table
    from harness.report.textout import ELLIPSIS, width, wrap
    from harness.store.runrecord import finite

    setup_store()
    targets, problems = expand(args.targets, args.targets_dir)
    targets = [with_testcases(t, args.testcases) for t in targets]
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
        wide = width() is None
        # the test case content hash only in the whole table (--wide) and in --json
        rows = [("target", "commit", "test case/run", *(("content",) if wide else ()), "reference", "result",
                 "consistency", "min C", "detail")]
        details = []
        for v in shown:
            run, reference = v.run, v.run.reference_run
            result, detail = result_and_detail(v)
            rows.append((run.target.name, run.build.commit[:10], f"{run.testcase.path}/{run.name}",
                         *((run.short_hash or "-",) if wide else ()),
                         f"{reference.target.name}@{reference.build.commit[:10]}" if reference is not None else "-",
                         result, level_word(run.consistency) if run.consistency else "-",
                         f"{run.consistency_min:.4g}" if run.consistency_min is not None else "-", detail))
            if detail:
                details.append(f"{run.target.name} {run.testcase.path}/{run.name}: {result}: {detail}")
        table = format_table(rows)
        print(table)
        if args.verbose and details:
            print("\nmessages:")
            print("\n".join(wrap(line) for line in details))
        elif ELLIPSIS in table:
            print("(messages cut to fit: -v prints them whole, --wide the whole table)")
    if args.junit:
        write_junit(report, args.junit)
        print(f"JUnit XML written to {args.junit}", file=sys.stderr if args.json else sys.stdout)
    counts = {status: sum(v.status == status for v in report.verdicts) for status in ("passed", "failed", "skipped")}
    print(f"{len(report.verdicts)} runs: {counts['passed']} passed, {counts['failed']} failed, "
          f"{counts['skipped']} not run; {len(report.problems)} problems", file=sys.stderr if args.json else sys.stdout)
    if counts["failed"] or report.problems:
        return 1
    return 5 if not report.verdicts else 0
