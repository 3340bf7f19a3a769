"""``harness list [TARGET ...] [--state STATE] [--all-builds]``: runs in the store with their state."""
NAME = "list"
HELP = "list runs of the current builds with their state, commit and test case content"


def configure(parser):
    parser.add_argument("targets", nargs="*", metavar="TARGET", help="target names (default: all)")
    parser.add_argument("--state", help="only runs in this state (failed, post_processed, outdated, ...)")
    parser.add_argument("--all-machines", action="store_true", help="runs of every machine, not only this one")
    parser.add_argument("--all-builds", action="store_true",
                        help="also runs of earlier builds and of earlier test case content (outdated)")


def run(args) -> int:
    from harness.store import setup_store

    setup_store()
    from harness.builds import current_build
    from harness.models import Run
    from harness.runner import format_table
    from harness.targets import load_targets

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
            current_build(definition, args.machine)  # resolves the revision now and records it
        runs = runs.filter(build__current=True, replaced=False)
    rows = [("machine", "target", "commit", "test case", "run", "content", "state", "reason", "consistency",
             "wall s")]
    for r in runs:
        rows.append((r.machine.name, r.target.name, r.build.commit[:10], r.testcase.path, r.name,
                     r.short_hash or "-", r.state, r.failure_reason or "", r.consistency or "",
                     f"{r.wall_time:.2f}" if r.wall_time is not None else "-"))
    print(format_table(rows) if len(rows) > 1 else "no runs")
    return 0
