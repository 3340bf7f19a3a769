"""``harness list [TARGET ...] [--state STATE] [-k PATTERN] [-q] [--json] [--all-builds]``: runs in the store.

Exit code 5 when a selection (targets, state, pattern) matches no run."""
import json

from harness.adapters.base import UserError
from harness.report.glossary import level_word
from harness.report.textout import width
from harness.store import setup_store

NAME = "list"
HELP = "list runs of the current builds with their state, commit and test case content"


def configure(parser):
    parser.add_argument("targets", nargs="*", metavar="TARGET", help="target names (default: all)")
    parser.add_argument("--state", help="only runs in this state (failed, post_processed, outdated, ...)")
    parser.add_argument("-k", dest="pattern", metavar="PATTERN", help="only runs whose 'testcase/run' match")
    parser.add_argument("-q", dest="quiet", action="store_true",
                        help="only failing runs: failed or inconsistent, and not accepted by a reviewer")
    parser.add_argument("--json", action="store_true", help="print the runs as JSON")
    parser.add_argument("--all-machines", action="store_true", help="runs of every machine, not only this one")
    parser.add_argument("--all-builds", action="store_true",
                        help="also runs of earlier builds and of earlier test case content (outdated)")


def run(args) -> int:
    setup_store()
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.config.targets import load_targets
    from harness.config.testcases import matches
    from harness.execution.builds import record_current_build
    from harness.execution.scheduler import format_table
    from harness.store.models import Run, Target
    from harness.store.runrecord import STATES, finite

    if args.state and args.state not in STATES:
        raise UserError(f"--state: unknown state {args.state!r} (known: {', '.join(STATES)})")
    unknown = sorted(set(args.targets) - set(Target.objects.filter(name__in=args.targets)
                                             .values_list("name", flat=True)))
    if unknown:
        raise UserError(f"unknown target {unknown[0]!r} (no runs of it in the store)")

    runs = Run.objects.select_related("target", "testcase", "build", "machine").order_by(
        "target__name", "testcase__path", "name", "-id")
    if not args.all_machines:
        runs = runs.filter(machine__name=args.machine)
    if args.targets:
        runs = runs.filter(target__name__in=args.targets)
    if args.state:
        runs = runs.filter(state=args.state)
    if not args.all_builds:
        # the same rule as check and status: the build of the commit the revision resolves to now
        definitions, _problems = load_targets(args.targets_dir)
        for definition in definitions.values():
            record_current_build(definition, args.machine)
        runs = runs.current()
    matched = [r for r in runs if matches(args.pattern, r.testcase.path, r.name)]
    # -q: the failing runs (harness.store.rules.is_failing), as "failing since" and `harness check` count them
    failing = set(runs.failing().values_list("pk", flat=True)) if args.quiet else set()
    selected = [r for r in matched if not args.quiet or r.pk in failing]
    if args.json:
        print(json.dumps(finite([{
            "machine": r.machine.name, "target": r.target.name, "commit": r.build.commit,
            "testcase": r.testcase.path, "run": r.name, "testcase_hash": r.testcase_hash, "state": r.state,
            "failure_reason": r.failure_reason, "consistency": r.consistency, "lowest_c": r.consistency_min,
            "wall_time": r.wall_time, "stepping_time": r.stepping_time, "folder": r.folder} for r in selected]),
            indent=1, allow_nan=False))
    else:
        # the machine only with --all-machines (else it is this one), the content hash only in the whole table
        # (--wide; --json has it): the state, reason and consistency are words a reader scans for, never cut
        machine, content = bool(args.all_machines), width() is None
        rows = [(*(("machine",) if machine else ()), "target", "commit", "test case", "run",
                 *(("content",) if content else ()), "state", "reason", "consistency", "wall s", "stepping s")]
        for r in selected:
            rows.append((*((r.machine.name,) if machine else ()), r.target.name, r.build.commit[:10],
                         r.testcase.path, r.name, *((r.short_hash or "-",) if content else ()),
                         r.get_state_display(), r.failure_reason or "",
                         level_word(r.consistency) if r.consistency else "",
                         f"{r.wall_time:.2f}" if r.wall_time is not None else "-",
                         f"{r.stepping_time:.3f}" if r.stepping_time is not None else "-"))
        print(format_table(rows, keep=("target", "state", "reason", "consistency")) if len(rows) > 1 else "no runs")
    return 5 if not matched and (args.targets or args.state or args.pattern) else 0
