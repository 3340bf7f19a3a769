"""``harness status [TARGET ...] [--json]``: per target, its current build and its runs per state.

The columns are explained in ``--help`` (``COLUMNS``), the states in the glossary's words (harness.report.glossary).
"""
import argparse
import json

from harness.store import setup_store

NAME = "status"
HELP = "summary per target: current build (commit) and its runs per state"

#: the table's short column headings for the run states (harness.store.models.Run.State) and the glossary's word
STATE_COLUMNS = {"not_executed": ("not exec", "not executed"), "executed": ("executed", "executed"),
                 "failed": ("failed", "failed"), "post_processed": ("post-proc", "post-processed"),
                 "consistency_checked": ("checked", "version-consistency-checked"),
                 "outdated": ("outdated", "outdated")}


def columns_help() -> str:
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    import textwrap

    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.report.glossary import STATES
    from harness.report.textout import DEFAULT_WIDTH

    lines = ["columns:",
             "  target         the target (targets/NAME.json)",
             "  reference      the target it is compared against (its reference target)",
             "  current build  the commit the target's revision (tag, branch, commit, HEAD; in brackets) resolves",
             "                 to now: the runs counted are of this build"]
    for heading, word in STATE_COLUMNS.values():
        lines.append(textwrap.fill(f"{heading:<13}  runs of the current build in state {word}: {STATES[word]}",
                                   width=DEFAULT_WIDTH, initial_indent="  ", subsequent_indent=" " * 17))
    lines.append("  older          runs of earlier builds of this target (they stay in the history; not counted)")
    return "\n".join(lines)


def configure(parser):
    parser.add_argument("targets", nargs="*", metavar="TARGET", help="target names (default: all)")
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = columns_help()


def run(args) -> int:
    setup_store()
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from django.db.models import Count

    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.config.targets import load_targets

    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.execution.builds import current_build, record_current_build
    from harness.execution.scheduler import format_table
    from harness.store.models import Run, Target

    definitions, _problems = load_targets(args.targets_dir)
    targets = Target.objects.order_by("name")
    if args.targets:
        targets = targets.filter(name__in=args.targets)
    states = [s for s, _ in Run.State.choices]
    rows = [("target", "reference", "current build", *(STATE_COLUMNS[s][0] for s in states), "older")]
    summary = []
    for target in targets:
        # a target with a definition file: its revision resolved now; an imported one: as recorded
        definition = definitions.get(target.name)
        build = (record_current_build(definition, args.machine) if definition is not None
                 else current_build(target.name, args.machine))
        runs = Run.objects.filter(target=target, machine__name=args.machine)
        counts = dict(runs.current(build).values_list("state").annotate(n=Count("id"))
                      .values_list("state", "n")) if build else {}
        older = runs.exclude(build=build).count() if build else runs.count()
        revision = definition.revision if definition else "-"
        rows.append((target.name, target.reference.name if target.reference else "-",
                     f"{build.commit[:10]} ({revision})" if build else f"not built ({revision})",
                     *(counts.get(s, 0) for s in states), older))
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
