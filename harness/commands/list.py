"""``harness list [TARGET ...] [--state STATE]``: runs in the store with their state."""
NAME = "list"
HELP = "list runs with their state"


def configure(parser):
    parser.add_argument("targets", nargs="*", metavar="TARGET", help="target names (default: all)")
    parser.add_argument("--state", help="only runs in this state (failed, post_processed, outdated, ...)")
    parser.add_argument("--all-machines", action="store_true", help="runs of every machine, not only this one")


def run(args) -> int:
    from harness.store import setup_store

    setup_store()
    from harness.models import Run
    from harness.runner import format_table
    runs = Run.objects.select_related("target", "testcase", "build", "machine").order_by(
        "target__name", "testcase__path", "name", "-id")
    if not args.all_machines:
        runs = runs.filter(machine__name=args.machine)
    if args.targets:
        runs = runs.filter(target__name__in=args.targets)
    if args.state:
        runs = runs.filter(state=args.state)
    rows = [("machine", "target", "commit", "test case", "run", "state", "reason", "consistency", "wall s")]
    for r in runs:
        rows.append((r.machine.name, r.target.name, r.build.commit[:10], r.testcase.path, r.name, r.state,
                     r.failure_reason or "", r.consistency or "",
                     f"{r.wall_time:.2f}" if r.wall_time is not None else "-"))
    print(format_table(rows) if len(rows) > 1 else "no runs")
    return 0
