"""``harness status [TARGET ...] [--json]``: per target, its current build and its runs per state."""
import json

NAME = "status"
HELP = "summary per target: current build (commit) and its runs per state"


def configure(parser):
    parser.add_argument("targets", nargs="*", metavar="TARGET", help="target names (default: all)")
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")


def run(args) -> int:
    from harness.store import setup_store

    setup_store()
    from django.db.models import Count

    from harness.builds import current_build
    from harness.models import Run, Target
    from harness.runner import format_table
    from harness.targets import load_targets

    definitions, _problems = load_targets(args.targets_dir)
    targets = Target.objects.order_by("name")
    if args.targets:
        targets = targets.filter(name__in=args.targets)
    states = [s for s, _ in Run.State.choices]
    rows = [("target", "reference", "revision", "current build", *states, "older")]
    summary = []
    for target in targets:
        # a target with a definition file: its revision resolved now; an imported one: as recorded
        definition = definitions.get(target.name)
        build = current_build(definition or target.name, args.machine)
        runs = Run.objects.filter(target=target, machine__name=args.machine)
        counts = dict(runs.filter(build=build, replaced=False).values_list("state").annotate(n=Count("id"))
                      .values_list("state", "n")) if build else {}
        older = runs.exclude(build=build).count() if build else runs.count()
        revision = definition.revision if definition else "-"
        rows.append((target.name, target.reference.name if target.reference else "-", revision,
                     build.commit[:10] if build else "not built", *(counts.get(s, 0) for s in states), older))
        summary.append({"target": target.name, "reference": target.reference.name if target.reference else None,
                        "revision": definition.revision if definition else None,
                        "commit": build.commit if build else None, "states": {s: counts.get(s, 0) for s in states},
                        "older_builds_runs": older})
    if args.json:
        print(json.dumps(summary, indent=1))
    else:
        print(format_table(rows) if len(rows) > 1 else "no targets in the store")
    if args.targets and not summary:
        return 5
    return 0
