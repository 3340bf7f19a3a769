"""``harness status``: per target, its current build and how many runs are in each state."""
NAME = "status"
HELP = "summary per target: current build and run states"


def configure(parser):
    parser.add_argument("targets", nargs="*", metavar="TARGET", help="target names (default: all in the store)")


def run(args) -> int:
    from harness.store import setup_store

    setup_store()
    from django.db.models import Count

    from harness.builds import current_build
    from harness.models import Run, Target
    from harness.runner import format_table
    targets = Target.objects.order_by("name")
    if args.targets:
        targets = targets.filter(name__in=args.targets)
    states = [s for s, _ in Run.State.choices]
    rows = [("target", "reference", "build", *states)]
    for target in targets:
        build = current_build(target.name, args.machine)
        counts = dict(Run.objects.filter(target=target, machine__name=args.machine).values_list("state")
                      .annotate(n=Count("id")).values_list("state", "n"))
        rows.append((target.name, target.reference.name if target.reference else "-",
                     build.commit[:10] if build else "not built", *(counts.get(s, 0) for s in states)))
    print(format_table(rows) if len(rows) > 1 else "no targets in the store")
    return 0
